/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_status.h"

#include <string.h>

#include "dxl_table.h"
#include "eeprom_store.h"
#include "emu_robot.h"

const robot_binding_t *emu_servo_joint(const emu_servos_t *v, size_t index) {
  return v->robot ? robot_model_binding(v->robot->model, v->slot_ids[index]) : NULL;
}

static const char *load_name(const ax12_load_t *load) {
  switch (load->kind) {
    case AX12_LOAD_CONSTANT: return "torque";
    case AX12_LOAD_SPRING: return "spring";
    case AX12_LOAD_ARM: return "arm";
    default: return "none";
  }
}

cJSON *emu_world_json(const plant_options_t *o) {
  cJSON *w = cJSON_CreateObject();
  cJSON_AddNumberToObject(w, "supply", o->supply_v);
  cJSON_AddNumberToObject(w, "ambient", o->ambient_c);
  cJSON_AddStringToObject(w, "load", load_name(&o->load));
  switch (o->load.kind) {
    case AX12_LOAD_CONSTANT: cJSON_AddNumberToObject(w, "load_torque_nm", o->load.torque_nm); break;
    case AX12_LOAD_SPRING:
      cJSON_AddNumberToObject(w, "spring_nm_rad", o->load.spring_nm_rad);
      cJSON_AddNumberToObject(w, "rest_deg", o->load.rest_rad * 180.0 / 3.14159265358979323846);
      break;
    case AX12_LOAD_ARM:
      cJSON_AddNumberToObject(w, "mass_kg", o->load.mass_kg);
      cJSON_AddNumberToObject(w, "arm_m", o->load.arm_m);
      cJSON_AddNumberToObject(w, "horizontal_deg", o->load.horizontal_rad * 180.0 / 3.14159265358979323846);
      break;
    default: break;
  }
  return w;
}

static unsigned table_u16(const uint8_t *t, unsigned address) { return t[address] | (unsigned)t[address + 1u] << 8; }

static cJSON *servo_json(const emu_servos_t *v, size_t index, bool with_table) {
  const servo_t *s = v->world->servos[index];
  servo_probe_t p;
  servo_probe_read(s, &v->map, &p);
  cJSON *j = cJSON_CreateObject();
  cJSON_AddNumberToObject(j, "slot", v->slot_ids[index]);
  cJSON_AddStringToObject(j, "name", s->name);
  cJSON_AddBoolToObject(j, "halted", s->halted);
  if (p.have_table) {
    const uint8_t *t = p.table;
    cJSON_AddNumberToObject(j, "id", t[CT_ADDR_ID]);
    cJSON_AddNumberToObject(j, "goal_position", table_u16(t, CT_ADDR_GOAL_POSITION));
    cJSON_AddNumberToObject(j, "present_position", table_u16(t, CT_ADDR_PRESENT_POSITION));
    cJSON_AddNumberToObject(j, "present_speed", table_u16(t, CT_ADDR_PRESENT_SPEED));
    cJSON_AddNumberToObject(j, "present_load", table_u16(t, CT_ADDR_PRESENT_LOAD));
    cJSON_AddNumberToObject(j, "present_voltage", t[CT_ADDR_PRESENT_VOLTAGE]);
    cJSON_AddNumberToObject(j, "present_temperature", t[CT_ADDR_PRESENT_TEMPERATURE]);
    cJSON_AddNumberToObject(j, "torque_enable", t[CT_ADDR_TORQUE_ENABLE]);
    cJSON_AddNumberToObject(j, "moving", t[CT_ADDR_MOVING]);
    cJSON_AddNumberToObject(j, "alarm_led", t[CT_ADDR_ALARM_LED]);
    cJSON_AddNumberToObject(j, "alarm_shutdown", t[CT_ADDR_ALARM_SHUTDOWN]);
    cJSON_AddNumberToObject(j, "conditions", p.conditions);
    if (with_table) {
      int values[CT_SIZE];
      for (unsigned a = 0; a < CT_SIZE; a++) {
        values[a] = t[a];
      }
      cJSON_AddItemToObject(j, "table", cJSON_CreateIntArray(values, CT_SIZE));
    }
  }
  cJSON_AddBoolToObject(j, "led", p.led_on);
  cJSON_AddNumberToObject(j, "duty", p.duty);
  if (p.has_plant) {
    cJSON_AddNumberToObject(j, "angle_deg", p.angle_deg);
    cJSON_AddNumberToObject(j, "speed_rpm", p.speed_rpm);
    cJSON_AddNumberToObject(j, "motor_current_a", p.motor_current_a);
    cJSON_AddNumberToObject(j, "winding_c", p.winding_c);
    cJSON_AddNumberToObject(j, "case_c", p.case_c);
    cJSON_AddNumberToObject(j, "supply_v", p.terminal_v);
    cJSON_AddNumberToObject(j, "load_torque_nm", p.load_torque_nm);
  }
  const robot_binding_t *joint = emu_servo_joint(v, index);
  if (joint) {
    /* its load is the robot: gravity and the robot's motion on the joint (MuJoCo's bias
     * force; contacts not counted) */
    cJSON_AddStringToObject(j, "joint", joint->name);
    cJSON_ReplaceItemInObject(j, "load_torque_nm",
                              cJSON_CreateNumber(-v->robot->physics.data->qfrc_bias[joint->dof]));
  }
  cJSON_AddItemToObject(j, "world", emu_world_json(&v->worlds[index]));
  return j;
}

static cJSON *delays_json(const delay_histogram_t *h) {
  cJSON *j = cJSON_CreateObject();
  cJSON_AddNumberToObject(j, "count", (double)h->count);
  cJSON_AddNumberToObject(j, "p50_ms", delay_histogram_quantile_us(h, 0.5) / 1e3);
  cJSON_AddNumberToObject(j, "p99_ms", delay_histogram_quantile_us(h, 0.99) / 1e3);
  cJSON_AddNumberToObject(j, "max_ms", h->max_us / 1e3);
  return j;
}

static cJSON *timing_json(const emu_servos_t *v) {
  cJSON *j = cJSON_CreateObject();
  char policy[sizeof(v->realtime->why_not) + 64];
  emu_realtime_describe(v->realtime, policy, sizeof(policy));
  cJSON_AddBoolToObject(j, "realtime", v->pacing->realtime);
  cJSON_AddStringToObject(j, "policy", policy);
  const char *state = !v->realtime->asked ? "fast" : !v->realtime->held ? "not allowed"
                      : v->pacing->rt.held ? "held" : "dropped";
  cJSON_AddStringToObject(j, "policy_state", state);
  if (v->pacing->realtime) {
    const double ahead_us = pacing_ahead_us(v->pacing, v->world->now);
    cJSON_AddNumberToObject(j, "lag_ms", ahead_us < 0.0 ? -ahead_us / 1e3 : 0.0);
    cJSON_AddNumberToObject(j, "worst_lag_ms", v->pacing->max_behind_us / 1e3);
    cJSON_AddNumberToObject(j, "speed", pacing_speed(v->pacing, v->world->now));
    cJSON_AddItemToObject(j, "to_client_late", delays_json(&v->pty->to_client_late));
  }
  cJSON_AddItemToObject(j, "to_bus_delay", delays_json(&v->pty->to_bus_delay));
  return j;
}

cJSON *emu_status_json(const emu_servos_t *v, bool event, bool with_table, const bool *only_slots, bool with_robot) {
  cJSON *j = cJSON_CreateObject();
  if (event) {
    cJSON_AddStringToObject(j, "event", "telemetry");
  } else {
    cJSON_AddBoolToObject(j, "ok", true);
    cJSON_AddStringToObject(j, "op", "status");
  }
  cJSON_AddNumberToObject(j, "time_us", sim_cycles_to_us(v->world->now));
  cJSON_AddStringToObject(j, "profile", eeprom_profile_name(v->world->profile));
  cJSON_AddStringToObject(j, "mcu", v->world->mcu);
  if (v->pacing) {
    cJSON_AddItemToObject(j, "timing", timing_json(v));
  }
  cJSON *servos = cJSON_AddArrayToObject(j, "servos");
  for (size_t i = 0; i < v->world->servo_count; i++) {
    if (only_slots && !only_slots[v->slot_ids[i]]) {
      continue;
    }
    cJSON_AddItemToArray(servos, servo_json(v, i, with_table));
  }
  if (with_robot && v->robot) {
    cJSON_AddItemToObject(j, "robot", emu_robot_pose_json(v->robot));
  }
  return j;
}

