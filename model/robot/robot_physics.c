/* SPDX-License-Identifier: MIT */
#include "robot_physics.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

bool robot_physics_init(robot_physics_t *p, robot_model_t *robot, double armature_kg_m2, char *err, size_t err_len) {
  memset(p, 0, sizeof(*p));
  mjModel *m = robot->model;
  p->robot = robot;
  p->data = mj_makeData(m);
  p->body_mass_kg = calloc((size_t)m->nbody, sizeof(double));
  p->payload_kg = calloc((size_t)m->nbody, sizeof(double));
  if (!p->data || !p->body_mass_kg || !p->payload_kg) {
    robot_physics_free(p);
    snprintf(err, err_len, "out of memory for the robot's physics");
    return false;
  }
  memcpy(p->body_mass_kg, m->body_mass, (size_t)m->nbody * sizeof(double));
  memcpy(p->gravity_m_s2, m->opt.gravity, sizeof(p->gravity_m_s2));
  p->gravity_on = true;
  for (size_t i = 0; i < robot->binding_count; i++) {
    const int dof = robot->bindings[i].dof;
    m->dof_armature[dof] = armature_kg_m2;
    m->dof_damping[dof] = 0.0;
    m->dof_frictionloss[dof] = 0.0;
    m->dof_solref[mjNREF * dof] = ROBOT_FRICTION_TIMECONST_STEPS * m->opt.timestep;
    m->dof_solref[mjNREF * dof + 1] = 1.0;
    m->dof_solimp[mjNIMP * dof] = ROBOT_FRICTION_IMPEDANCE;
    m->dof_solimp[mjNIMP * dof + 1] = ROBOT_FRICTION_IMPEDANCE;
  }
  if (robot->start_key >= 0) {
    mj_resetDataKeyframe(m, p->data, robot->start_key);
  }
  mj_forward(m, p->data);
  return true;
}

void robot_physics_free(robot_physics_t *p) {
  if (p->data) {
    mj_deleteData(p->data);
  }
  free(p->body_mass_kg);
  free(p->payload_kg);
  p->data = NULL;
  p->body_mass_kg = p->payload_kg = NULL;
}

void robot_physics_set_joint(robot_physics_t *p, size_t binding, double applied_nm, double damping_nm_s_rad,
                             double frictionloss_nm) {
  mjModel *m = p->robot->model;
  const int dof = p->robot->bindings[binding].dof;
  p->data->qfrc_applied[dof] = applied_nm;
  m->dof_damping[dof] = damping_nm_s_rad;
  m->dof_frictionloss[dof] = frictionloss_nm;
}

void robot_physics_step(robot_physics_t *p) {
  const mjModel *m = p->robot->model;
  mjData *d = p->data;
  /* the pushes under way, summed; each counts its steps down */
  memset(d->xfrc_applied, 0, (size_t)m->nbody * 6u * sizeof(mjtNum));
  size_t kept = 0;
  for (size_t i = 0; i < p->push_count; i++) {
    robot_push_t *push = &p->pushes[i];
    for (int k = 0; k < 3; k++) {
      d->xfrc_applied[6 * push->body + k] += push->force_n[k];
    }
    if (--push->steps_left) {
      p->pushes[kept++] = *push;
    }
  }
  p->push_count = kept;
  mj_step(m, d);
  p->steps++;
}


double robot_physics_joint_angle_rad(const robot_physics_t *p, size_t binding) {
  return p->data->qpos[p->robot->bindings[binding].qpos];
}

double robot_physics_joint_speed_rad_s(const robot_physics_t *p, size_t binding) {
  return p->data->qvel[p->robot->bindings[binding].dof];
}

int robot_physics_body(const robot_physics_t *p, const char *body, char *err, size_t err_len) {
  const int b = body ? mj_name2id(p->robot->model, mjOBJ_BODY, body) : -1;
  if (b < 0) {
    snprintf(err, err_len, "no body '%s' in the robot", body ? body : "");
    return -1;
  }
  if (b == 0) {
    snprintf(err, err_len, "the world body does not move: name one of the robot's bodies");
    return -1;
  }
  return b;
}

bool robot_physics_payload_valid(double payload_kg, char *err, size_t err_len) {
  if (!(payload_kg >= 0.0 && payload_kg <= ROBOT_PAYLOAD_MAX_KG)) {
    snprintf(err, err_len, "a payload is 0..%g kg", ROBOT_PAYLOAD_MAX_KG);
    return false;
  }
  return true;
}

bool robot_physics_push_valid(const robot_physics_t *p, const double force_n[3], double seconds, size_t pushes,
                              char *err, size_t err_len) {
  for (int k = 0; k < 3; k++) {
    if (!(fabs(force_n[k]) <= ROBOT_PUSH_MAX_N)) {
      snprintf(err, err_len, "a push's force is within +-%g N along each axis", ROBOT_PUSH_MAX_N);
      return false;
    }
  }
  if (!(seconds > 0.0 && seconds <= ROBOT_PUSH_MAX_S)) {
    snprintf(err, err_len, "a push lasts more than 0 and at most %g s", ROBOT_PUSH_MAX_S);
    return false;
  }
  if (p->push_count + pushes > ROBOT_MAX_PUSHES) {
    snprintf(err, err_len, "at most %u pushes at a time", ROBOT_MAX_PUSHES);
    return false;
  }
  return true;
}

bool robot_physics_set_payload(robot_physics_t *p, const char *body, double payload_kg, char *err, size_t err_len) {
  const int b = robot_physics_body(p, body, err, err_len);
  if (b < 0 || !robot_physics_payload_valid(payload_kg, err, err_len)) {
    return false;
  }
  p->payload_kg[b] = payload_kg;
  p->robot->model->body_mass[b] = p->body_mass_kg[b] + payload_kg;
  return true;
}

bool robot_physics_push(robot_physics_t *p, const char *body, const double force_n[3], double seconds, char *err,
                        size_t err_len) {
  const int b = robot_physics_body(p, body, err, err_len);
  if (b < 0 || !robot_physics_push_valid(p, force_n, seconds, 1, err, err_len)) {
    return false;
  }
  const double steps = round(seconds / p->robot->model->opt.timestep);
  robot_push_t *push = &p->pushes[p->push_count++];
  *push = (robot_push_t){.body = b, .steps_left = steps < 1.0 ? 1u : (uint64_t)steps};
  memcpy(push->force_n, force_n, sizeof(push->force_n));
  return true;
}

void robot_physics_set_gravity(robot_physics_t *p, bool on) {
  p->gravity_on = on;
  for (int k = 0; k < 3; k++) {
    p->robot->model->opt.gravity[k] = on ? p->gravity_m_s2[k] : 0.0;
  }
}
