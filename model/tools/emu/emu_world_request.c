/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_world_request.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "servo_plant.h"

/* The servos a request names: "id" a slot ID of --ids (the ID the servo was started with),
 * or "all" / absent. Returns false with err set for an unknown one. */
static bool selected_servos(const emu_servos_t *v, const cJSON *req, bool *selected, char *err, size_t err_len) {
  const cJSON *id = cJSON_GetObjectItemCaseSensitive(req, "id");
  const bool all = id == NULL || (cJSON_IsString(id) && strcmp(id->valuestring, "all") == 0);
  if (!all && !cJSON_IsNumber(id)) {
    snprintf(err, err_len, "\"id\" must be a servo's ID (as in --ids) or \"all\"");
    return false;
  }
  bool any = false;
  for (size_t i = 0; i < v->world->servo_count; i++) {
    selected[i] = all || (double)v->slot_ids[i] == id->valuedouble;
    any |= selected[i];
  }
  if (!any) {
    snprintf(err, err_len, "no servo %g on this bus", id->valuedouble);
  }
  return any;
}

/* A JSON value as the command line's text: a number, a string, or an array of numbers
 * (joined by commas, as --load-spring 2,150). */
static bool option_text(const cJSON *value, char *out, size_t len) {
  if (cJSON_IsNumber(value)) {
    snprintf(out, len, "%.17g", value->valuedouble);
    return true;
  }
  if (cJSON_IsString(value)) {
    snprintf(out, len, "%s", value->valuestring);
    return true;
  }
  if (!cJSON_IsArray(value) || cJSON_GetArraySize(value) == 0) {
    return false;
  }
  size_t used = 0;
  const cJSON *v;
  cJSON_ArrayForEach(v, value) {
    if (!cJSON_IsNumber(v)) {
      return false;
    }
    const int n = snprintf(out + used, len - used, "%s%.17g", used ? "," : "", v->valuedouble);
    if (n < 0 || (size_t)n >= len - used) {
      return false;
    }
    used += (size_t)n;
  }
  return true;
}

/* Applies "set" to one servo's world options; false with err set (o then partly changed:
 * the caller works on a copy). */
static bool parse_world_changes(plant_options_t *o, const cJSON *set, char *err, size_t err_len) {
  bool load_given = false;
  const cJSON *item;
  cJSON_ArrayForEach(item, set) {
    const char *name = item->string;
    const bool is_load = strncmp(name, "load-", 5) == 0;
    if (is_load && load_given) {
      snprintf(err, err_len, "one load at a time");
      return false;
    }
    if (strcmp(name, "angle") == 0) {
      snprintf(err, err_len, "angle is only set at start (--angle): the servo's shaft is where the physics put it");
      return false;
    }
    if (strcmp(name, "load-none") == 0) {
      o->load = ax12_load_none();
      o->load_option = NULL;
      load_given = true;
      continue;
    }
    char text[128];
    if (!option_text(item, text, sizeof text)) {
      snprintf(err, err_len, "bad value for %s: a number, or numbers in an array", name);
      return false;
    }
    if (is_load) {
      o->load_option = NULL; /* a new load replaces the one there */
      load_given = true;
    }
    if (!plant_options_parse(o, name, text, err, err_len)) {
      return false;
    }
  }
  return true;
}

static void apply_world(servo_t *servo, const plant_options_t *o) {
  if (!servo->has_plant) {
    return;
  }
  ax12_plant_set_supply_v(&servo->plant, o->supply_v);
  ax12_plant_set_ambient_c(&servo->plant, o->ambient_c);
  if (!servo->plant_on_joint) {
    ax12_plant_set_load(&servo->plant, &o->load);
  }
  servo_show_plant(servo);
}

cJSON *emu_world_request(emu_servos_t *v, const cJSON *req, char *err, size_t err_len) {
  bool selected[WORLD_MAX_SERVOS];
  if (!selected_servos(v, req, selected, err, err_len)) {
    return NULL;
  }
  const cJSON *set = cJSON_GetObjectItemCaseSensitive(req, "set");
  if (set != NULL && !cJSON_IsObject(set)) {
    snprintf(err, err_len, "\"set\" must be an object of world options");
    return NULL;
  }
  /* Every selected servo's new world is checked before any is changed. */
  plant_options_t *changed = calloc(v->world->servo_count, sizeof(*changed));
  if (!changed) {
    snprintf(err, err_len, "out of memory");
    return NULL;
  }
  for (size_t i = 0; i < v->world->servo_count; i++) {
    changed[i] = v->worlds[i];
    if (selected[i] && set && !parse_world_changes(&changed[i], set, err, err_len)) {
      free(changed);
      return NULL;
    }
    const robot_binding_t *joint = emu_servo_joint(v, i);
    if (selected[i] && joint && changed[i].load.kind != AX12_LOAD_NONE) {
      snprintf(err, err_len, "servo %u is joint '%s' of the robot: its load is the robot (change the robot's world "
               "with \"op\":\"robot\": payload, push, gravity)", v->slot_ids[i], joint->name);
      free(changed);
      return NULL;
    }
  }
  cJSON *reply = cJSON_CreateObject();
  cJSON_AddBoolToObject(reply, "ok", true);
  cJSON_AddStringToObject(reply, "op", "world");
  cJSON *servos = cJSON_AddArrayToObject(reply, "servos");
  for (size_t i = 0; i < v->world->servo_count; i++) {
    if (!selected[i]) {
      continue;
    }
    if (set) {
      v->worlds[i] = changed[i];
      v->worlds[i].load_option = NULL;
      apply_world(v->world->servos[i], &v->worlds[i]);
    }
    cJSON *s = cJSON_CreateObject();
    cJSON_AddNumberToObject(s, "slot", v->slot_ids[i]);
    cJSON_AddItemToObject(s, "world", emu_world_json(&v->worlds[i]));
    cJSON_AddItemToArray(servos, s);
  }
  free(changed);
  return reply;
}
