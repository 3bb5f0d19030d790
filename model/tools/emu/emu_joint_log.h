/* SPDX-License-Identifier: GPL-3.0-or-later */
/* `serve --robot ... --log-joints FILE.csv`: the robot's qpos after every physics step, one CSV
 * row each: `time_us` (the world's simulated time, as --log-bus's, four decimals: exact) and
 * every qpos entry of the model by the joint it belongs to (a hinge or slide: its name; a
 * free joint: NAME_x, _y, _z, _qw, _qx, _qy, _qz; a ball: NAME_qw.._qz), 17 significant
 * digits, so two files are equal exactly when the trajectories are equal bit for bit
 * (docs/robot.md "Lock-step"). Rows are flushed every 100 ms of wall time and at the end. */
#ifndef EMU_JOINT_LOG_H
#define EMU_JOINT_LOG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

#include "world_robot.h"

typedef struct {
  FILE *file;
  double last_flush_us;
  bool failed;
} emu_joint_log_t;

/* Creates path, writes the header and hooks the robot's steps; -1 with err set. */
int emu_joint_log_start(emu_joint_log_t *log, const char *path, world_robot_t *robot, char *err, size_t err_len);
/* Every slice of the serve loop: flushes when 100 ms of wall time have passed. */
void emu_joint_log_tick(emu_joint_log_t *log);
/* Unhooks, flushes and closes: -1 (a line on stderr) when a write failed. */
int emu_joint_log_stop(emu_joint_log_t *log, world_robot_t *robot);

#endif
