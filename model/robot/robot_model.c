/* SPDX-License-Identifier: MIT */
#include "robot_model.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define DEG_PER_RAD (180.0 / 3.14159265358979323846)
#define CYCLES_PER_MS 16000u /* the servos' 16 MHz clock: the physics steps on whole cycles */

static void warn_line(const char *message) {
  /* one line: MuJoCo's messages may hold newlines */
  fputs("robot: MuJoCo: ", stderr);
  for (const char *p = message; *p; p++) {
    fputc(*p == '\n' ? ' ' : *p, stderr);
  }
  fputc('\n', stderr);
}

static void fatal(const char *message) {
  warn_line(message);
  exit(1);
}

void robot_model_install_handlers(void) {
  mju_user_warning = warn_line;
  mju_user_error = fatal;
}

static bool ends_with(const char *s, const char *suffix) {
  const size_t n = strlen(s), m = strlen(suffix);
  return n >= m && strcmp(s + n - m, suffix) == 0;
}

/* The file of spec: a path as it is, a name in robots_dir. */
static bool resolve(const char *spec, const char *robots_dir, char *path, size_t len, char *err, size_t err_len) {
  if (!spec[0]) {
    snprintf(err, err_len, "empty robot (%s, or an MJCF file's path)", ROBOT_BUILTIN_NAMES);
    return false;
  }
  if (strchr(spec, '/') || ends_with(spec, ".xml")) {
    snprintf(path, len, "%s", spec);
    if (access(path, R_OK) != 0) {
      snprintf(err, err_len, "cannot read the model file %s", spec);
      return false;
    }
    return true;
  }
  snprintf(path, len, "%s/%s.xml", robots_dir, spec);
  if (access(path, R_OK) != 0) {
    snprintf(err, err_len, "unknown robot '%s' (%s, or an MJCF file's path)", spec, ROBOT_BUILTIN_NAMES);
    return false;
  }
  return true;
}

/* MuJoCo's message on one line: its lines joined with "; " (" " after a colon). */
static void one_line(const char *text, char *out, size_t len) {
  size_t used = 0;
  for (const char *p = text; *p && used + 3 < len; p++) {
    if (*p == '\r') {
      continue;
    }
    if (*p != '\n') {
      out[used++] = *p;
    } else if (p[1] && p[1] != '\n' && used > 0) {
      if (out[used - 1] != ':') {
        out[used++] = ';';
      }
      out[used++] = ' ';
    }
  }
  while (used && out[used - 1] == ' ') {
    used--;
  }
  out[used] = '\0';
}

static const char *joint_name(const mjModel *m, int joint) {
  const char *name = mj_id2name(m, mjOBJ_JOINT, joint);
  return name ? name : "(unnamed)";
}

/* The joint's angle at the start: the keyframe's, else qpos0. */
static double start_angle_rad(const robot_model_t *r, const robot_binding_t *b) {
  const mjModel *m = r->model;
  return r->start_key >= 0 ? m->key_qpos[(size_t)r->start_key * (size_t)m->nq + (size_t)b->qpos] : m->qpos0[b->qpos];
}

static bool check_binding(robot_model_t *r, int numeric, char *err, size_t err_len) {
  const mjModel *m = r->model;
  const char *label = mj_id2name(m, mjOBJ_NUMERIC, numeric);
  const char *joint = label + strlen(ROBOT_BINDING_PREFIX);
  const double value = m->numeric_data[m->numeric_adr[numeric]];
  if (m->numeric_size[numeric] != 1 || !(value >= 0.0 && value <= ROBOT_MAX_ID) || value != floor(value)) {
    snprintf(err, err_len, "binding %s: its data must be one servo ID, a whole number 0..%u", label, ROBOT_MAX_ID);
    return false;
  }
  const int j = mj_name2id(m, mjOBJ_JOINT, joint);
  if (j < 0) {
    snprintf(err, err_len, "binding %s names no joint '%s' of the model", label, joint);
    return false;
  }
  const uint8_t id = (uint8_t)value;
  for (size_t i = 0; i < r->binding_count; i++) {
    if (r->bindings[i].id == id) {
      snprintf(err, err_len, "joints '%s' and '%s' are both bound to servo %u: one joint per servo", r->bindings[i].name,
               joint_name(m, j), id);
      return false;
    }
  }
  if (m->jnt_type[j] != mjJNT_HINGE) {
    snprintf(err, err_len, "joint '%s' (servo %u) is not a hinge: a servo's output turns", joint_name(m, j), id);
    return false;
  }
  robot_binding_t *b = &r->bindings[r->binding_count];
  *b = (robot_binding_t){.id = id, .joint = j, .dof = m->jnt_dofadr[j], .qpos = m->jnt_qposadr[j],
                         .name = joint_name(m, j)};
  const double lo = m->jnt_range[2 * j] * DEG_PER_RAD, hi = m->jnt_range[2 * j + 1] * DEG_PER_RAD;
  if (m->jnt_limited[j] && (lo < -ROBOT_POT_HALF_TRACK_DEG - 1e-9 || hi > ROBOT_POT_HALF_TRACK_DEG + 1e-9)) {
    snprintf(err, err_len,
             "joint '%s' (servo %u) ranges %g..%g deg, outside the pot's track (-150..150 deg about Goal Position 512)",
             b->name, id, lo, hi);
    return false;
  }
  const double start = start_angle_rad(r, b) * DEG_PER_RAD;
  if (!(fabs(start) <= ROBOT_POT_HALF_TRACK_DEG)) {
    snprintf(err, err_len, "joint '%s' (servo %u) starts at %g deg, outside the pot's track (-150..150 deg)", b->name,
             id, start);
    return false;
  }
  r->binding_count++;
  return true;
}

/* The physics' steps per millisecond: the fewest that keep its timestep at or below the
 * model's and on whole cycles of the 16 MHz clock (a divisor of 16000). */
static unsigned steps_per_ms(double timestep_s) {
  unsigned k = 1;
  while (k < CYCLES_PER_MS && (1e-3 / k > timestep_s * (1.0 + 1e-9) || CYCLES_PER_MS % k != 0)) {
    k++;
  }
  return k;
}

static bool check(robot_model_t *r, char *err, size_t err_len) {
  mjModel *m = r->model;
  if (!(m->opt.timestep > 0.0)) {
    snprintf(err, err_len, "timestep %g s: a timestep is above 0", m->opt.timestep);
    return false;
  }
  r->steps_per_ms = steps_per_ms(m->opt.timestep);
  const double timestep_s = 1e-3 / r->steps_per_ms;
  if (fabs(timestep_s - m->opt.timestep) > 1e-12) {
    snprintf(r->note, sizeof(r->note), "its timestep %g s is stepped as %g s (the physics steps at 1 ms or a divisor of it)",
             m->opt.timestep, timestep_s);
    m->opt.timestep = timestep_s;
  }
  r->start_key = mj_name2id(m, mjOBJ_KEY, ROBOT_START_KEY);
  for (int i = 0; i < m->nnumeric; i++) {
    const char *label = mj_id2name(m, mjOBJ_NUMERIC, i);
    if (label && strncmp(label, ROBOT_BINDING_PREFIX, strlen(ROBOT_BINDING_PREFIX)) == 0 &&
        !check_binding(r, i, err, err_len)) {
      return false;
    }
  }
  if (r->binding_count == 0) {
    snprintf(err, err_len, "binds no joint to a servo (<custom><numeric name=\"%sJOINT\" data=\"ID\"/></custom>)",
             ROBOT_BINDING_PREFIX);
    return false;
  }
  return true;
}

bool robot_model_load(robot_model_t *r, const char *spec, const char *robots_dir, char *err, size_t err_len) {
  memset(r, 0, sizeof(*r));
  r->start_key = -1;
  robot_model_install_handlers();
  if (!resolve(spec, robots_dir, r->path, sizeof(r->path), err, err_len)) {
    return false;
  }
  char load_error[1024] = "";
  r->model = mj_loadXML(r->path, NULL, load_error, sizeof(load_error));
  if (!r->model) {
    char reason[1024];
    one_line(load_error, reason, sizeof reason);
    snprintf(err, err_len, "%s does not load: %s", r->path, reason[0] ? reason : "(no reason given)");
    return false;
  }
  const char *model_name = r->model->names; /* the model's name comes first */
  if (model_name && model_name[0]) {
    snprintf(r->name, sizeof(r->name), "%s", model_name);
  } else {
    const char *base = strrchr(r->path, '/');
    snprintf(r->name, sizeof(r->name), "%.*s", (int)sizeof(r->name) - 1, base ? base + 1 : r->path);
    char *dot = strrchr(r->name, '.');
    if (dot) {
      *dot = '\0';
    }
  }
  if (!check(r, err, err_len)) {
    robot_model_free(r);
    return false;
  }
  return true;
}

void robot_model_free(robot_model_t *r) {
  if (r->model) {
    mj_deleteModel(r->model);
  }
  r->model = NULL;
  r->binding_count = 0;
}

const robot_binding_t *robot_model_binding(const robot_model_t *r, uint8_t id) {
  for (size_t i = 0; i < r->binding_count; i++) {
    if (r->bindings[i].id == id) {
      return &r->bindings[i];
    }
  }
  return NULL;
}
