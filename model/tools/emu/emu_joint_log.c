/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_joint_log.h"

#include <errno.h>
#include <string.h>

#include "pacing.h"

#define FLUSH_PERIOD_US 100000.0

static void write_header(FILE *f, const mjModel *m) {
  static const char *const free_parts[] = {"x", "y", "z", "qw", "qx", "qy", "qz"};
  fputs("time_us", f);
  for (int j = 0; j < m->njnt; j++) {
    const char *name = mj_id2name(m, mjOBJ_JOINT, j);
    char unnamed[32];
    if (!name) {
      snprintf(unnamed, sizeof unnamed, "joint%d", j);
      name = unnamed;
    }
    switch (m->jnt_type[j]) {
    case mjJNT_FREE:
      for (int k = 0; k < 7; k++) {
        fprintf(f, ",%s_%s", name, free_parts[k]);
      }
      break;
    case mjJNT_BALL:
      for (int k = 3; k < 7; k++) {
        fprintf(f, ",%s_%s", name, free_parts[k]);
      }
      break;
    default:
      fprintf(f, ",%s", name);
    }
  }
  fputc('\n', f);
}

static void write_row(world_robot_t *robot, void *ctx) {
  emu_joint_log_t *log = ctx;
  if (log->failed) {
    return;
  }
  const sim_cycles_t now = robot->world->now;
  fprintf(log->file, "%llu.%04llu", (unsigned long long)(now / SIM_CYCLES_PER_US),
          (unsigned long long)(now % SIM_CYCLES_PER_US * 10000u / SIM_CYCLES_PER_US));
  const mjModel *m = robot->model->model;
  const mjtNum *qpos = robot->physics.data->qpos;
  for (int i = 0; i < m->nq; i++) {
    fprintf(log->file, ",%.17g", qpos[i]);
  }
  if (fputc('\n', log->file) == EOF) {
    log->failed = true;
    fprintf(stderr, "ax12-emu: --log-joints: %s; the joint log stops here\n", strerror(errno));
  }
}

int emu_joint_log_start(emu_joint_log_t *log, const char *path, world_robot_t *robot, char *err, size_t err_len) {
  memset(log, 0, sizeof(*log));
  log->file = fopen(path, "w");
  if (!log->file) {
    snprintf(err, err_len, "--log-joints %s: %s", path, strerror(errno));
    return -1;
  }
  write_header(log->file, robot->model->model);
  log->last_flush_us = pacing_wall_us();
  robot->after_physics = write_row;
  robot->after_physics_ctx = log;
  return 0;
}

void emu_joint_log_tick(emu_joint_log_t *log) {
  if (!log->file || log->failed) {
    return;
  }
  const double wall = pacing_wall_us();
  if (wall - log->last_flush_us >= FLUSH_PERIOD_US) {
    log->last_flush_us = wall;
    if (fflush(log->file) != 0) {
      log->failed = true;
      fprintf(stderr, "ax12-emu: --log-joints: %s; the joint log stops here\n", strerror(errno));
    }
  }
}

int emu_joint_log_stop(emu_joint_log_t *log, world_robot_t *robot) {
  if (!log->file) {
    return 0;
  }
  robot->after_physics = NULL;
  bool failed = log->failed;
  if (fclose(log->file) != 0 && !failed) {
    failed = true;
    fprintf(stderr, "ax12-emu: --log-joints: %s\n", strerror(errno));
  }
  log->file = NULL;
  return failed ? -1 : 0;
}
