/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A robot in the world (docs/robot.md): each bound joint of a MuJoCo model (robot_model.h) is
 * the output shaft of one of the world's servos, and the robot's physics steps in lock with
 * the servos in simulated time.
 *
 * The world's simulated time owns the clock. The physics steps once every timestep of the
 * model (1 ms or a divisor of it) at exact multiples of it from the time it was attached; no
 * step of the world passes the next one (world_t.physics_due). When the world reaches it,
 * every bound servo's plant is stepped to that time, the drive each summed since the last
 * physics step becomes its joint's torque, the physics advances one timestep to that time,
 * and each plant takes its joint's new angle and speed (the pot shows them: the physics is
 * never ahead of the firmwares). Between physics steps a plant's pot advances at its joint's
 * last speed. So the same bus traffic at the same simulated times gives the same joint
 * trajectories bit for bit, whatever the wall clock does; while gdb holds a servo the world,
 * and so the robot, stands still. */
#ifndef SIM_WORLD_ROBOT_H
#define SIM_WORLD_ROBOT_H

#include <stdbool.h>
#include <stddef.h>

#include "robot_physics.h"
#include "world.h"

/* The output angle (plant.h) at joint angle 0: the pot's centre, Goal Position 512. */
#define WORLD_ROBOT_CENTRE_RAD (150.0 * 3.14159265358979323846 / 180.0)

typedef struct world_robot {
  world_t *world;
  robot_model_t *model;
  robot_physics_t physics;
  servo_t *servos[ROBOT_MAX_BINDINGS]; /* by binding */
  sim_cycles_t period;                 /* the model's timestep in cycles */
  /* Optional: called after every physics step (the joint log of `serve --log-joints`). */
  void (*after_physics)(struct world_robot *robot, void *ctx);
  void *after_physics_ctx;
} world_robot_t;

/* Binds the world's servos to the model's joints: servos[i] is binding i's servo (each with a
 * plant: servo_attach_plant). The plants' loads are dropped, their shafts put at the joints'
 * start angles, and the physics is stepped from the world's time on. The model is the
 * robot's from now on (changed by the world's changes; freed by the caller after
 * world_robot_detach). False with err set. */
bool world_robot_attach(world_robot_t *robot, world_t *world, robot_model_t *model, servo_t *const *servos,
                        char *err, size_t err_len);
/* Unbinds the servos (their plants stay where the joints left them) and frees the physics. */
void world_robot_detach(world_robot_t *robot);

/* The physics' time, simulated seconds since it was attached: its steps times its timestep. */
double world_robot_time_s(const world_robot_t *robot);

#endif
