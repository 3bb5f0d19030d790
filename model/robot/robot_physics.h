/* SPDX-License-Identifier: MIT */
/* A robot's rigid-body physics (MuJoCo) stepped one timestep at a time by its owner, with the
 * torques of its bound joints set before each step, and the world a user changes while it
 * runs: a payload on a body, a push on a body for a time, gravity off and on
 * (docs/robot.md). Deterministic: the same torques give the same states, bit for bit
 * (MuJoCo on one thread).
 *
 * The bound joints' armature and the stiffness of their friction are set here once
 * (robot_physics_init); damping and frictionloss with each step's torques. The model's own
 * values for them are replaced: a servo's are its gearbox's (plant_joint.h), counted once. */
#ifndef ROBOT_PHYSICS_H
#define ROBOT_PHYSICS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "robot_model.h"

/* The bound joints' friction as a stiff constraint (dof_solimp, dof_solref): MuJoCo's default
 * lets a joint held by friction creep at a speed proportional to the torque it holds
 * (0.7 deg/s for the pendulum hanging 10 deg off vertical); this impedance and a time constant
 * of two timesteps bring that under 1e-4 deg/s. */
#define ROBOT_FRICTION_IMPEDANCE 0.9999
#define ROBOT_FRICTION_TIMECONST_STEPS 2.0

#define ROBOT_MAX_PUSHES 16u
#define ROBOT_PAYLOAD_MAX_KG 10.0
#define ROBOT_PUSH_MAX_N 1000.0
#define ROBOT_PUSH_MAX_S 10.0

typedef struct {
  int body;
  double force_n[3];   /* world frame, at the body's centre of mass */
  uint64_t steps_left; /* timesteps it still acts */
} robot_push_t;

typedef struct {
  robot_model_t *robot; /* the model, owned by the caller, changed by the world's changes */
  mjData *data;
  double gravity_m_s2[3]; /* the model's */
  bool gravity_on;
  double *body_mass_kg;   /* the model's masses, per body */
  double *payload_kg;     /* per body */
  robot_push_t pushes[ROBOT_MAX_PUSHES];
  size_t push_count;
  uint64_t steps;
} robot_physics_t;

/* Data at the start state (keyframe "start", else qpos0), positions computed; the bound joints
 * get armature_kg_m2 and a friction that holds (no creep). False with err set (out of memory). */
bool robot_physics_init(robot_physics_t *p, robot_model_t *robot, double armature_kg_m2, char *err, size_t err_len);
void robot_physics_free(robot_physics_t *p);

/* Binding i's terms for the next step: applied_nm - damping x speed, friction up to frictionloss. */
void robot_physics_set_joint(robot_physics_t *p, size_t binding, double applied_nm, double damping_nm_s_rad,
                             double frictionloss_nm);

/* One timestep (the model's), the pushes under way applied. */
void robot_physics_step(robot_physics_t *p);

double robot_physics_joint_angle_rad(const robot_physics_t *p, size_t binding);
double robot_physics_joint_speed_rad_s(const robot_physics_t *p, size_t binding);

/* The world. The setters return false with err set (and change nothing) for an unknown body
 * or a value out of range; the checks alone, for a request of several changes checked before
 * any is made: */
/* A body that moves, by name: its id, or -1 with err set. */
int robot_physics_body(const robot_physics_t *p, const char *body, char *err, size_t err_len);
bool robot_physics_payload_valid(double payload_kg, char *err, size_t err_len);
/* pushes: how many more are asked for at once (room is checked for all of them). */
bool robot_physics_push_valid(const robot_physics_t *p, const double force_n[3], double seconds, size_t pushes,
                              char *err, size_t err_len);
/* payload_kg (0..ROBOT_PAYLOAD_MAX_KG) at the body's centre of mass, replacing the one there. */
bool robot_physics_set_payload(robot_physics_t *p, const char *body, double payload_kg, char *err, size_t err_len);
/* force_n (world frame, each component within +-ROBOT_PUSH_MAX_N) on the body's centre of
 * mass from the next step, for seconds (> 0, at most ROBOT_PUSH_MAX_S; whole timesteps,
 * at least one). */
bool robot_physics_push(robot_physics_t *p, const char *body, const double force_n[3], double seconds, char *err,
                        size_t err_len);
void robot_physics_set_gravity(robot_physics_t *p, bool on);

#endif
