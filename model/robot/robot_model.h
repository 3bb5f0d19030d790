/* SPDX-License-Identifier: MIT */
/* A robot of AX-12s: a MuJoCo model (MJCF) whose hinge joints are bound to servo IDs
 * (docs/robot.md "Binding joints to servos"). One custom numeric per bound joint:
 *
 *   <custom><numeric name="ax12:shoulder" data="2"/></custom>
 *
 * makes joint "shoulder" the output shaft of servo 2. A bound joint is a hinge whose angle 0
 * is the pot's centre (Goal Position 512) and whose positive direction is the servo's
 * counter-clockwise (counts rising); its range, when it has one, lies within the pot's track
 * (-150..+150 deg), and so does its angle at the start (qpos0, or the keyframe "start" when
 * the model has one). The physics steps at 1 ms or a divisor of it, on whole cycles of the
 * 16 MHz clock: a model's timestep that is not one becomes the next one below it (2 ms, MuJoCo's
 * default, becomes 1 ms), which robot_model_t.note says. Loading checks all of it before anything runs; what
 * fails is one line in err.
 *
 * MuJoCo's warnings go to stderr as one line each ("robot: MuJoCo: ..."); its fatal errors
 * (out of memory) print and exit(1). */
#ifndef ROBOT_MODEL_H
#define ROBOT_MODEL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <mujoco/mujoco.h>

#define ROBOT_MAX_BINDINGS 254u
#define ROBOT_MAX_ID 253u
/* The pot's track either side of its centre, in the joint's angle. */
#define ROBOT_POT_HALF_TRACK_DEG 150.0
/* The prefix of a binding's custom numeric. */
#define ROBOT_BINDING_PREFIX "ax12:"
/* The keyframe a model starts from when it has one. */
#define ROBOT_START_KEY "start"

typedef struct {
  uint8_t id;        /* the servo's slot ID (--ids) */
  int joint;         /* MuJoCo joint id */
  int dof;           /* its dof address (qvel, qfrc, dof_*) */
  int qpos;          /* its qpos address */
  const char *name;  /* the joint's name, in the model */
} robot_binding_t;

typedef struct {
  mjModel *model;
  char path[4096];           /* the MJCF file */
  char name[64];             /* the model's name (<mujoco model=...>), else the file's stem */
  int start_key;             /* the keyframe "start", -1 when none */
  unsigned steps_per_ms;     /* 1 ms / timestep (the model's timestep is set to it) */
  char note[160];            /* what loading changed (the timestep), for the user; "" when nothing */
  robot_binding_t bindings[ROBOT_MAX_BINDINGS];
  size_t binding_count;      /* in the order of the model's custom numerics */
} robot_model_t;

/* Where the robots shipped with the project are (model/robots/NAME.xml). */
#define ROBOT_BUILTIN_NAMES "pendulum, arm, hexapod"

/* Loads `spec`: a shipped robot's name (robots_dir/NAME.xml; a name has no '/' and does not
 * end in ".xml") or an MJCF file's path, and checks its bindings. False with one line in err
 * (and nothing loaded) when the model does not load or a binding is wrong. */
bool robot_model_load(robot_model_t *r, const char *spec, const char *robots_dir, char *err, size_t err_len);
void robot_model_free(robot_model_t *r);

/* The binding of servo `id`, NULL when no joint is bound to it. */
const robot_binding_t *robot_model_binding(const robot_model_t *r, uint8_t id);

/* Routes MuJoCo's warnings and errors to stderr (done by robot_model_load). */
void robot_model_install_handlers(void);

#endif
