/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_robot.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEG_PER_RAD (180.0 / 3.14159265358979323846)
/* Positions to 1 um, orientations and sizes to 1e-6: the numbers a page draws, without the
 * 17 digits cJSON would print. */
#define POSE_DECIMALS 6

/* n numbers as a JSON array with `decimals` digits after the point. */
static cJSON *numbers(const double *v, size_t n, int decimals) {
  char text[64 * 16];
  size_t used = 0;
  text[used++] = '[';
  for (size_t i = 0; i < n && used < sizeof(text) - 40u; i++) {
    const double x = fabs(v[i]) < 0.5 * pow(10.0, -decimals) ? 0.0 : v[i]; /* no "-0.000000" */
    used += (size_t)snprintf(text + used, sizeof(text) - used, "%s%.*f", i ? "," : "", decimals, x);
  }
  snprintf(text + used, sizeof(text) - used, "]");
  return cJSON_CreateRaw(text);
}

static cJSON *floats(const float *v, size_t n) {
  double d[16];
  for (size_t i = 0; i < n && i < 16u; i++) {
    d[i] = v[i];
  }
  return numbers(d, n, 4);
}

static const char *geom_type_name(int type) {
  switch (type) {
  case mjGEOM_PLANE: return "plane";
  case mjGEOM_HFIELD: return "hfield";
  case mjGEOM_SPHERE: return "sphere";
  case mjGEOM_CAPSULE: return "capsule";
  case mjGEOM_ELLIPSOID: return "ellipsoid";
  case mjGEOM_CYLINDER: return "cylinder";
  case mjGEOM_BOX: return "box";
  case mjGEOM_MESH: return "mesh";
  default: return "other";
  }
}

static void add_name(cJSON *j, const mjModel *m, int type, int id) {
  const char *name = mj_id2name(m, type, id);
  if (name) {
    cJSON_AddStringToObject(j, "name", name);
  } else {
    cJSON_AddNullToObject(j, "name");
  }
}

static cJSON *geom_json(const mjModel *m, int g) {
  cJSON *j = cJSON_CreateObject();
  add_name(j, m, mjOBJ_GEOM, g);
  cJSON_AddNumberToObject(j, "body", m->geom_bodyid[g]);
  cJSON_AddStringToObject(j, "type", geom_type_name(m->geom_type[g]));
  cJSON_AddItemToObject(j, "size", numbers(m->geom_size + 3 * g, 3, POSE_DECIMALS));
  cJSON_AddItemToObject(j, "pos", numbers(m->geom_pos + 3 * g, 3, POSE_DECIMALS));
  cJSON_AddItemToObject(j, "quat", numbers(m->geom_quat + 4 * g, 4, POSE_DECIMALS));
  const int mat = m->geom_matid[g];
  cJSON_AddItemToObject(j, "rgba", floats(mat >= 0 ? m->mat_rgba + 4 * mat : m->geom_rgba + 4 * g, 4));
  cJSON_AddNumberToObject(j, "group", m->geom_group[g]);
  cJSON_AddBoolToObject(j, "collides", m->geom_contype[g] != 0 || m->geom_conaffinity[g] != 0);
  if (m->geom_type[g] == mjGEOM_MESH) {
    cJSON_AddNumberToObject(j, "mesh", m->geom_dataid[g]);
  }
  return j;
}

/* A mesh's vertices (in the frame its geoms' pos and quat place) and its triangles. */
static cJSON *mesh_json(const mjModel *m, int k) {
  cJSON *j = cJSON_CreateObject();
  add_name(j, m, mjOBJ_MESH, k);
  cJSON *vertices = cJSON_AddArrayToObject(j, "vertices");
  const float *v = m->mesh_vert + 3 * m->mesh_vertadr[k];
  for (int i = 0; i < 3 * m->mesh_vertnum[k]; i++) {
    cJSON_AddItemToArray(vertices, cJSON_CreateNumber(round(v[i] * 1e6) / 1e6));
  }
  cJSON *faces = cJSON_AddArrayToObject(j, "faces");
  const int *f = m->mesh_face + 3 * m->mesh_faceadr[k];
  for (int i = 0; i < 3 * m->mesh_facenum[k]; i++) {
    cJSON_AddItemToArray(faces, cJSON_CreateNumber(f[i]));
  }
  return j;
}

static cJSON *joint_json(const world_robot_t *r, int jnt) {
  const mjModel *m = r->model->model;
  cJSON *j = cJSON_CreateObject();
  add_name(j, m, mjOBJ_JOINT, jnt);
  static const char *const types[] = {"free", "ball", "slide", "hinge"};
  cJSON_AddStringToObject(j, "type", m->jnt_type[jnt] >= 0 && m->jnt_type[jnt] <= 3 ? types[m->jnt_type[jnt]] : "other");
  cJSON_AddNumberToObject(j, "body", m->jnt_bodyid[jnt]);
  cJSON_AddItemToObject(j, "pos", numbers(m->jnt_pos + 3 * jnt, 3, POSE_DECIMALS));
  cJSON_AddItemToObject(j, "axis", numbers(m->jnt_axis + 3 * jnt, 3, POSE_DECIMALS));
  if (m->jnt_limited[jnt] && m->jnt_type[jnt] == mjJNT_HINGE) {
    const double range_deg[2] = {m->jnt_range[2 * jnt] * DEG_PER_RAD, m->jnt_range[2 * jnt + 1] * DEG_PER_RAD};
    cJSON_AddItemToObject(j, "range_deg", numbers(range_deg, 2, 3));
  }
  for (size_t i = 0; i < r->model->binding_count; i++) {
    if (r->model->bindings[i].joint == jnt) {
      cJSON_AddNumberToObject(j, "servo", r->model->bindings[i].id);
    }
  }
  return j;
}

cJSON *emu_robot_world_json(const world_robot_t *r) {
  const robot_physics_t *p = &r->physics;
  const mjModel *m = r->model->model;
  cJSON *w = cJSON_CreateObject();
  cJSON_AddBoolToObject(w, "gravity", p->gravity_on);
  cJSON_AddItemToObject(w, "gravity_m_s2", numbers(p->gravity_m_s2, 3, 5));
  cJSON *payloads = cJSON_AddArrayToObject(w, "payloads");
  for (int b = 1; b < m->nbody; b++) {
    if (p->payload_kg[b] > 0.0) {
      cJSON *item = cJSON_CreateObject();
      cJSON_AddStringToObject(item, "body", mj_id2name(m, mjOBJ_BODY, b) ? mj_id2name(m, mjOBJ_BODY, b) : "");
      cJSON_AddNumberToObject(item, "kg", p->payload_kg[b]);
      cJSON_AddItemToArray(payloads, item);
    }
  }
  cJSON *pushes = cJSON_AddArrayToObject(w, "pushes");
  for (size_t i = 0; i < p->push_count; i++) {
    const robot_push_t *push = &p->pushes[i];
    cJSON *item = cJSON_CreateObject();
    cJSON_AddStringToObject(item, "body", mj_id2name(m, mjOBJ_BODY, push->body) ? mj_id2name(m, mjOBJ_BODY, push->body) : "");
    cJSON_AddItemToObject(item, "force_n", numbers(push->force_n, 3, 3));
    cJSON_AddNumberToObject(item, "seconds_left", (double)push->steps_left * m->opt.timestep);
    cJSON_AddItemToArray(pushes, item);
  }
  return w;
}

cJSON *emu_robot_pose_json(const world_robot_t *r) {
  const mjModel *m = r->model->model;
  const mjData *d = r->physics.data;
  cJSON *j = cJSON_CreateObject();
  cJSON_AddNumberToObject(j, "time_s", world_robot_time_s(r));
  cJSON_AddNumberToObject(j, "steps", (double)r->physics.steps);
  /* every body's [x, y, z, qw, qx, qy, qz] in one raw array */
  const size_t per = 7u * (size_t)m->nbody;
  char *text = malloc(per * 16u + 8u);
  if (text) {
    size_t used = 0;
    text[used++] = '[';
    for (int b = 0; b < m->nbody; b++) {
      double v[7];
      memcpy(v, d->xpos + 3 * b, 3 * sizeof(double));
      memcpy(v + 3, d->xquat + 4 * b, 4 * sizeof(double));
      used += (size_t)snprintf(text + used, per * 16u + 8u - used, "%s[", b ? "," : "");
      for (int k = 0; k < 7; k++) {
        const double x = fabs(v[k]) < 5e-7 ? 0.0 : v[k];
        used += (size_t)snprintf(text + used, per * 16u + 8u - used, "%s%.*f", k ? "," : "", POSE_DECIMALS, x);
      }
      text[used++] = ']';
    }
    text[used++] = ']';
    text[used] = '\0';
    cJSON_AddItemToObject(j, "poses", cJSON_CreateRaw(text));
    free(text);
  }
  cJSON_AddItemToObject(j, "world", emu_robot_world_json(r));
  return j;
}

cJSON *emu_robot_description_json(const world_robot_t *r) {
  const mjModel *m = r->model->model;
  cJSON *j = cJSON_CreateObject();
  cJSON_AddStringToObject(j, "name", r->model->name);
  cJSON_AddStringToObject(j, "file", r->model->path);
  cJSON_AddNumberToObject(j, "timestep_s", m->opt.timestep);
  cJSON *bodies = cJSON_AddArrayToObject(j, "bodies");
  for (int b = 0; b < m->nbody; b++) {
    cJSON *body = cJSON_CreateObject();
    add_name(body, m, mjOBJ_BODY, b);
    cJSON_AddNumberToObject(body, "parent", b ? m->body_parentid[b] : -1);
    cJSON_AddNumberToObject(body, "mass_kg", r->physics.body_mass_kg[b]);
    cJSON_AddItemToArray(bodies, body);
  }
  cJSON *joints = cJSON_AddArrayToObject(j, "joints");
  for (int jnt = 0; jnt < m->njnt; jnt++) {
    cJSON_AddItemToArray(joints, joint_json(r, jnt));
  }
  cJSON *geoms = cJSON_AddArrayToObject(j, "geoms");
  for (int g = 0; g < m->ngeom; g++) {
    cJSON_AddItemToArray(geoms, geom_json(m, g));
  }
  cJSON *meshes = cJSON_AddArrayToObject(j, "meshes");
  for (int k = 0; k < m->nmesh; k++) {
    cJSON_AddItemToArray(meshes, mesh_json(m, k));
  }
  cJSON_AddItemToObject(j, "world", emu_robot_world_json(r));
  cJSON_AddItemToObject(j, "pose", emu_robot_pose_json(r));
  return j;
}

/* ---- changes ---------------------------------------------------------------------------- */

typedef struct {
  int body;
  double kg;
} payload_change_t;

typedef struct {
  int body;
  double force_n[3];
  double seconds;
} push_change_t;

#define MAX_CHANGES 16

static bool number_field(const cJSON *item, const char *name, double *value) {
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(item, name);
  if (!cJSON_IsNumber(v)) {
    return false;
  }
  *value = v->valuedouble;
  return true;
}

static int body_field(const world_robot_t *r, const cJSON *item, char *err, size_t err_len) {
  const cJSON *body = cJSON_GetObjectItemCaseSensitive(item, "body");
  if (!cJSON_IsString(body)) {
    snprintf(err, err_len, "\"body\" must be the name of one of the robot's bodies");
    return -1;
  }
  return robot_physics_body(&r->physics, body->valuestring, err, err_len);
}

/* "payload" or "push": one object or an array of them. */
static bool items_of(const cJSON *value, const cJSON **items, size_t *count, const char *what, char *err,
                     size_t err_len) {
  *count = 0;
  if (cJSON_IsObject(value)) {
    items[(*count)++] = value;
    return true;
  }
  const cJSON *item;
  if (cJSON_IsArray(value)) {
    cJSON_ArrayForEach(item, value) {
      if (!cJSON_IsObject(item) || *count == MAX_CHANGES) {
        break;
      }
      items[(*count)++] = item;
    }
    if ((int)*count == cJSON_GetArraySize(value) && *count > 0) {
      return true;
    }
  }
  snprintf(err, err_len, "\"%s\" must be an object (or an array of up to %d): %s", what, MAX_CHANGES,
           strcmp(what, "payload") == 0 ? "{\"body\": NAME, \"kg\": KG}"
                                        : "{\"body\": NAME, \"force_n\": [FX, FY, FZ], \"seconds\": S}");
  return false;
}

cJSON *emu_robot_request(world_robot_t *r, const cJSON *req, char *err, size_t err_len) {
  const cJSON *set = cJSON_GetObjectItemCaseSensitive(req, "set");
  if (set == NULL) {
    cJSON *answer = cJSON_CreateObject();
    cJSON_AddBoolToObject(answer, "ok", true);
    cJSON_AddStringToObject(answer, "op", "robot");
    cJSON_AddItemToObject(answer, "robot", emu_robot_description_json(r));
    return answer;
  }
  if (!cJSON_IsObject(set) || cJSON_GetArraySize(set) == 0) {
    snprintf(err, err_len, "\"set\" must be an object of changes: payload, push, gravity");
    return NULL;
  }
  payload_change_t payloads[MAX_CHANGES];
  push_change_t pushes[MAX_CHANGES];
  size_t payload_count = 0, push_count = 0;
  int gravity = -1;
  const cJSON *change;
  cJSON_ArrayForEach(change, set) {
    const cJSON *items[MAX_CHANGES];
    size_t n = 0;
    if (strcmp(change->string, "gravity") == 0) {
      if (!cJSON_IsBool(change)) {
        snprintf(err, err_len, "\"gravity\" must be true or false");
        return NULL;
      }
      gravity = cJSON_IsTrue(change);
    } else if (strcmp(change->string, "payload") == 0) {
      if (!items_of(change, items, &n, "payload", err, err_len)) {
        return NULL;
      }
      if (payload_count + n > MAX_CHANGES) {
        snprintf(err, err_len, "at most %d payloads in one request", MAX_CHANGES);
        return NULL;
      }
      for (size_t i = 0; i < n; i++) {
        payload_change_t *c = &payloads[payload_count++];
        if ((c->body = body_field(r, items[i], err, err_len)) < 0) {
          return NULL;
        }
        if (!number_field(items[i], "kg", &c->kg)) {
          snprintf(err, err_len, "a payload needs \"kg\": a number");
          return NULL;
        }
        if (!robot_physics_payload_valid(c->kg, err, err_len)) {
          return NULL;
        }
      }
    } else if (strcmp(change->string, "push") == 0) {
      if (!items_of(change, items, &n, "push", err, err_len)) {
        return NULL;
      }
      if (push_count + n > MAX_CHANGES) {
        snprintf(err, err_len, "at most %d pushes in one request", MAX_CHANGES);
        return NULL;
      }
      for (size_t i = 0; i < n; i++) {
        push_change_t *c = &pushes[push_count++];
        if ((c->body = body_field(r, items[i], err, err_len)) < 0) {
          return NULL;
        }
        const cJSON *force = cJSON_GetObjectItemCaseSensitive(items[i], "force_n");
        if (!cJSON_IsArray(force) || cJSON_GetArraySize(force) != 3) {
          snprintf(err, err_len, "a push needs \"force_n\": [FX, FY, FZ] in newtons, world frame (z up)");
          return NULL;
        }
        for (int k = 0; k < 3; k++) {
          const cJSON *f = cJSON_GetArrayItem(force, k);
          if (!cJSON_IsNumber(f)) {
            snprintf(err, err_len, "a push's \"force_n\" holds three numbers");
            return NULL;
          }
          c->force_n[k] = f->valuedouble;
        }
        if (!number_field(items[i], "seconds", &c->seconds)) {
          snprintf(err, err_len, "a push needs \"seconds\": how long it acts");
          return NULL;
        }
        if (!robot_physics_push_valid(&r->physics, c->force_n, c->seconds, push_count, err, err_len)) {
          return NULL;
        }
      }
    } else {
      snprintf(err, err_len, "unknown change \"%s\" (payload, push, gravity)", change->string);
      return NULL;
    }
  }
  /* every change checked: make them */
  const mjModel *m = r->model->model;
  for (size_t i = 0; i < payload_count; i++) {
    (void)robot_physics_set_payload(&r->physics, mj_id2name(m, mjOBJ_BODY, payloads[i].body), payloads[i].kg, err,
                                    err_len);
  }
  for (size_t i = 0; i < push_count; i++) {
    (void)robot_physics_push(&r->physics, mj_id2name(m, mjOBJ_BODY, pushes[i].body), pushes[i].force_n,
                             pushes[i].seconds, err, err_len);
  }
  if (gravity >= 0) {
    robot_physics_set_gravity(&r->physics, gravity == 1);
  }
  cJSON *answer = cJSON_CreateObject();
  cJSON_AddBoolToObject(answer, "ok", true);
  cJSON_AddStringToObject(answer, "op", "robot");
  cJSON_AddNumberToObject(answer, "time_s", world_robot_time_s(r));
  cJSON_AddItemToObject(answer, "world", emu_robot_world_json(r));
  return answer;
}
