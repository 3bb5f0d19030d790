/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "world_robot.h"

#include <stdio.h>
#include <string.h>

#include "plant_joint.h"
#include "servo_plant.h"

static void show_joint(world_robot_t *r, size_t i) {
  servo_t *servo = r->servos[i];
  ax12_plant_joint_set_motion(&servo->plant, WORLD_ROBOT_CENTRE_RAD + robot_physics_joint_angle_rad(&r->physics, i),
                              robot_physics_joint_speed_rad_s(&r->physics, i));
  servo_show_plant(servo);
}

static sim_cycles_t physics_step(world_t *world, void *ctx) {
  world_robot_t *r = ctx;
  const size_t n = r->model->binding_count;
  for (size_t i = 0; i < n; i++) {
    servo_t *servo = r->servos[i];
    servo_step_plant(servo, world->now, true);
    const ax12_joint_torque_t t = ax12_plant_joint_take(&servo->plant, &servo->joint_drive);
    robot_physics_set_joint(&r->physics, i, t.applied_nm, t.damping_nm_s_rad, t.frictionloss_nm);
  }
  robot_physics_step(&r->physics);
  for (size_t i = 0; i < n; i++) {
    show_joint(r, i);
  }
  if (r->after_physics) {
    r->after_physics(r, r->after_physics_ctx);
  }
  return world->now + r->period;
}

bool world_robot_attach(world_robot_t *r, world_t *world, robot_model_t *model, servo_t *const *servos, char *err,
                        size_t err_len) {
  memset(r, 0, sizeof(*r));
  if (world->physics_step) {
    snprintf(err, err_len, "the world has a robot already");
    return false;
  }
  for (size_t i = 0; i < model->binding_count; i++) {
    if (!servos[i] || !servos[i]->has_plant) {
      snprintf(err, err_len, "joint '%s': servo %u has no plant", model->bindings[i].name, model->bindings[i].id);
      return false;
    }
  }
  const ax12_plant_t *plant = &servos[0]->plant;
  if (!robot_physics_init(&r->physics, model, ax12_plant_joint_armature_kg_m2(plant), err, err_len)) {
    return false;
  }
  r->world = world;
  r->model = model;
  r->period = SIM_CYCLES_PER_US * 1000u / model->steps_per_ms;
  const ax12_load_t none = ax12_load_none();
  for (size_t i = 0; i < model->binding_count; i++) {
    servo_t *servo = servos[i];
    r->servos[i] = servo;
    servo_step_plant(servo, world->now, true);
    ax12_plant_set_load(&servo->plant, &none);
    servo->joint_drive = (ax12_joint_drive_t){0};
    servo->plant_on_joint = true;
    show_joint(r, i);
  }
  world->physics_ctx = r;
  world->physics_step = physics_step;
  world->physics_due = world->now + r->period;
  return true;
}

void world_robot_detach(world_robot_t *r) {
  if (!r->world) {
    return;
  }
  for (size_t i = 0; i < r->model->binding_count; i++) {
    r->servos[i]->plant_on_joint = false;
  }
  r->world->physics_step = NULL;
  r->world->physics_ctx = NULL;
  r->world->physics_due = SIM_CYCLES_NEVER;
  robot_physics_free(&r->physics);
  r->world = NULL;
}

double world_robot_time_s(const world_robot_t *r) {
  return (double)(r->physics.steps * r->period) / (double)SIM_CPU_HZ; /* exact, where MuJoCo's time sums timesteps */
}
