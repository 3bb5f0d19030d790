/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_control.h"

#include <cjson/cJSON.h>
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dxl_protocol.h"
#include "pacing.h"
#include "servo_plant.h"

/* A packet goes on the bus once it has been silent this long: longer than the longest Return
 * Delay Time (254 x 2 us), so no servo is about to answer the client. */
#define IDLE_BEFORE_SEND_US 600u
/* A reply is over when no byte came for this many byte times after the last one, or when
 * none came this long after the request (the longest Return Delay Time, with room). */
#define REPLY_GAP_BYTES 10u
#define REPLY_WAIT_US 1500u
#define TELEMETRY_HZ_MAX 100.0
/* Packets go to subscribers in batches at most this far apart (wall clock). */
#define PACKET_BATCH_PERIOD_US 50000.0
/* The socket is looked at this often (wall clock) while no packet of "send" is under way. */
#define POLL_PERIOD_US 1000.0

static void send_json(emu_control_t *c, unsigned client, cJSON *json) {
  char *text = cJSON_PrintUnformatted(json);
  if (text) {
    control_socket_send(&c->socket, client, text);
    free(text);
  }
  cJSON_Delete(json);
}

static void send_error(emu_control_t *c, unsigned client, const char *op, const char *message) {
  cJSON *reply = cJSON_CreateObject();
  cJSON_AddBoolToObject(reply, "ok", false);
  if (op) {
    cJSON_AddStringToObject(reply, "op", op);
  }
  cJSON_AddStringToObject(reply, "error", message);
  send_json(c, client, reply);
}

/* ---- status ---------------------------------------------------------------------------- */

static const char *load_name(const ax12_load_t *load) {
  switch (load->kind) {
    case AX12_LOAD_CONSTANT: return "torque";
    case AX12_LOAD_SPRING: return "spring";
    case AX12_LOAD_ARM: return "arm";
    default: return "none";
  }
}

static cJSON *world_json(const plant_options_t *o) {
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

static cJSON *servo_json(const emu_control_t *c, size_t index, bool with_table) {
  const servo_t *s = c->world->servos[index];
  servo_probe_t p;
  servo_probe_read(s, &c->map, &p);
  cJSON *j = cJSON_CreateObject();
  cJSON_AddNumberToObject(j, "slot", c->slot_ids[index]);
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
  cJSON_AddItemToObject(j, "world", world_json(&c->worlds[index]));
  return j;
}

/* The answer to "status" (event false) or a pushed "telemetry" event. */
static cJSON *status_json(const emu_control_t *c, bool event, bool with_table) {
  cJSON *j = cJSON_CreateObject();
  if (event) {
    cJSON_AddStringToObject(j, "event", "telemetry");
  } else {
    cJSON_AddBoolToObject(j, "ok", true);
    cJSON_AddStringToObject(j, "op", "status");
  }
  cJSON_AddNumberToObject(j, "time_us", sim_cycles_to_us(c->world->now));
  cJSON_AddStringToObject(j, "profile", eeprom_profile_name(c->world->profile));
  cJSON_AddStringToObject(j, "mcu", c->world->mcu);
  cJSON *servos = cJSON_AddArrayToObject(j, "servos");
  for (size_t i = 0; i < c->world->servo_count; i++) {
    cJSON_AddItemToArray(servos, servo_json(c, i, with_table));
  }
  return j;
}

/* ---- world ----------------------------------------------------------------------------- */

/* The servos a request names: "id" a slot ID of --ids (the ID the servo was started with),
 * or "all" / absent. Returns false with err set for an unknown one. */
static bool selected_servos(const emu_control_t *c, const cJSON *req, bool *selected, char *err, size_t err_len) {
  const cJSON *id = cJSON_GetObjectItemCaseSensitive(req, "id");
  const bool all = id == NULL || (cJSON_IsString(id) && strcmp(id->valuestring, "all") == 0);
  if (!all && !cJSON_IsNumber(id)) {
    snprintf(err, err_len, "\"id\" must be a servo's ID (as in --ids) or \"all\"");
    return false;
  }
  bool any = false;
  for (size_t i = 0; i < c->world->servo_count; i++) {
    selected[i] = all || (double)c->slot_ids[i] == id->valuedouble;
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
  ax12_plant_set_load(&servo->plant, &o->load);
  servo_show_plant(servo);
}

static void handle_world(emu_control_t *c, unsigned client, const cJSON *req) {
  bool selected[WORLD_MAX_SERVOS];
  char err[256];
  if (!selected_servos(c, req, selected, err, sizeof err)) {
    send_error(c, client, "world", err);
    return;
  }
  const cJSON *set = cJSON_GetObjectItemCaseSensitive(req, "set");
  if (set != NULL && !cJSON_IsObject(set)) {
    send_error(c, client, "world", "\"set\" must be an object of world options");
    return;
  }
  /* Every selected servo's new world is checked before any is changed. */
  plant_options_t *changed = calloc(c->world->servo_count, sizeof(*changed));
  if (!changed) {
    send_error(c, client, "world", "out of memory");
    return;
  }
  for (size_t i = 0; i < c->world->servo_count; i++) {
    changed[i] = c->worlds[i];
    if (selected[i] && set && !parse_world_changes(&changed[i], set, err, sizeof err)) {
      send_error(c, client, "world", err);
      free(changed);
      return;
    }
  }
  cJSON *reply = cJSON_CreateObject();
  cJSON_AddBoolToObject(reply, "ok", true);
  cJSON_AddStringToObject(reply, "op", "world");
  cJSON *servos = cJSON_AddArrayToObject(reply, "servos");
  for (size_t i = 0; i < c->world->servo_count; i++) {
    if (!selected[i]) {
      continue;
    }
    if (set) {
      c->worlds[i] = changed[i];
      c->worlds[i].load_option = NULL;
      apply_world(c->world->servos[i], &c->worlds[i]);
    }
    cJSON *s = cJSON_CreateObject();
    cJSON_AddNumberToObject(s, "slot", c->slot_ids[i]);
    cJSON_AddItemToObject(s, "world", world_json(&c->worlds[i]));
    cJSON_AddItemToArray(servos, s);
  }
  free(changed);
  send_json(c, client, reply);
}

/* ---- send: a packet on the bus --------------------------------------------------------- */

/* "FF FF 01 02 01 FB", "ffff010201fb" or an array of numbers. */
static bool parse_bytes(const cJSON *value, uint8_t *out, size_t *len) {
  *len = 0;
  if (cJSON_IsArray(value)) {
    const cJSON *v;
    cJSON_ArrayForEach(v, value) {
      if (!cJSON_IsNumber(v) || v->valuedouble < 0 || v->valuedouble > 255 || v->valuedouble != (int)v->valuedouble ||
          *len == EMU_CONTROL_PACKET_MAX) {
        return false;
      }
      out[(*len)++] = (uint8_t)v->valueint;
    }
    return *len > 0;
  }
  if (!cJSON_IsString(value)) {
    return false;
  }
  int nibble = -1;
  for (const char *p = value->valuestring; *p; p++) {
    if (isspace((unsigned char)*p)) {
      if (nibble >= 0) {
        return false; /* an odd digit */
      }
      continue;
    }
    if (!isxdigit((unsigned char)*p)) {
      return false;
    }
    const int digit = isdigit((unsigned char)*p) ? *p - '0' : (tolower((unsigned char)*p) - 'a' + 10);
    if (nibble < 0) {
      nibble = digit;
    } else {
      if (*len == EMU_CONTROL_PACKET_MAX) {
        return false;
      }
      out[(*len)++] = (uint8_t)(nibble << 4 | digit);
      nibble = -1;
    }
  }
  return nibble < 0 && *len > 0;
}

/* A Protocol 1.0 instruction packet with a good checksum and a LENGTH that matches. */
static bool valid_instruction_packet(const uint8_t *b, size_t len, char *err, size_t err_len) {
  if (len < 6u || b[0] != 0xFF || b[1] != 0xFF || b[2] == 0xFF) {
    snprintf(err, err_len, "not a Protocol 1.0 packet (FF FF ID LENGTH INSTRUCTION ... CHECKSUM)");
    return false;
  }
  if ((size_t)b[3] + 4u != len) {
    snprintf(err, err_len, "LENGTH %u does not match the %zu bytes given", b[3], len);
    return false;
  }
  return true; /* a bad checksum is sent as it is: the servo answers it as the protocol says */
}

static void handle_send(emu_control_t *c, unsigned client, const cJSON *req) {
  emu_control_send_t job = {.client = client};
  char err[160];
  if (!parse_bytes(cJSON_GetObjectItemCaseSensitive(req, "bytes"), job.bytes, &job.len)) {
    send_error(c, client, "send", "\"bytes\" must be hex digits (\"FF FF 01 02 01 FB\") or an array of 0..255");
    return;
  }
  if (!valid_instruction_packet(job.bytes, job.len, err, sizeof err)) {
    send_error(c, client, "send", err);
    return;
  }
  if (c->queue_count == EMU_CONTROL_QUEUE) {
    send_error(c, client, "send", "too many packets waiting for the bus");
    return;
  }
  c->queue[(c->queue_head + c->queue_count++) % EMU_CONTROL_QUEUE] = job;
}

static sim_cycles_t bus_last_activity(const bus_t *bus) {
  sim_cycles_t last = 0;
  for (size_t i = 0; i < bus->node_count; i++) {
    if (bus->nodes[i].tx_end > last) {
      last = bus->nodes[i].tx_end;
    }
  }
  return last;
}

/* The master speaks at the baud of the servo addressed (the first servo for broadcast). */
static void choose_baud(emu_control_t *c, uint8_t id) {
  size_t chosen = 0;
  for (size_t i = 0; i < c->world->servo_count; i++) {
    servo_probe_t p;
    servo_probe_read(c->world->servos[i], &c->map, &p);
    if (p.have_table && p.table[CT_ADDR_ID] == id) {
      chosen = i;
      break;
    }
  }
  servo_probe_t p;
  servo_probe_read(c->world->servos[chosen], &c->map, &p);
  master_set_baud_reg(c->master, p.have_table ? p.table[CT_ADDR_BAUD_RATE] : 1u);
}

static void start_send(emu_control_t *c) {
  const emu_control_send_t *job = &c->queue[c->queue_head];
  choose_baud(c, job->bytes[2]);
  pty_bridge_hold(c->pty, true);
  master_rx_clear(c->master);
  c->request_end = master_send(c->master, job->bytes, job->len);
  c->last_rx_end = 0;
  c->sending = true;
}

static sim_cycles_t byte_cycles(const emu_control_t *c) { return (sim_cycles_t)(c->master->cycles_per_bit * 10.0); }

/* True once the reply is complete or no more of it can come. */
static bool reply_over(emu_control_t *c) {
  const sim_cycles_t now = c->world->now;
  if (now < c->request_end) {
    return false;
  }
  uint8_t got[EMU_CONTROL_PACKET_MAX];
  const size_t n = master_rx_values(c->master, got, sizeof got);
  if (n) {
    c->last_rx_end = master_rx(c->master, n - 1u)->end;
    if (n >= 4u && got[0] == 0xFF && got[1] == 0xFF && n >= (size_t)got[3] + 4u) {
      return true;
    }
    return now >= c->last_rx_end + REPLY_GAP_BYTES * byte_cycles(c);
  }
  return now >= c->request_end + sim_us(REPLY_WAIT_US) + REPLY_GAP_BYTES * byte_cycles(c);
}

static void finish_send(emu_control_t *c) {
  const emu_control_send_t *job = &c->queue[c->queue_head];
  uint8_t got[EMU_CONTROL_PACKET_MAX];
  const size_t n = master_rx_values(c->master, got, sizeof got);
  pty_bridge_hold(c->pty, false);
  c->sending = false;
  c->sent_packets++;
  cJSON *reply = cJSON_CreateObject();
  cJSON_AddBoolToObject(reply, "ok", true);
  cJSON_AddStringToObject(reply, "op", "send");
  char hex[3u * EMU_CONTROL_PACKET_MAX + 1u] = "";
  for (size_t i = 0; i < n; i++) {
    snprintf(hex + (i ? 3u * i - 1u : 0u), 4u, i ? " %02X" : "%02X", got[i]);
  }
  cJSON_AddStringToObject(reply, "reply", n ? hex : "");
  cJSON_AddNumberToObject(reply, "time_us", sim_cycles_to_us(c->world->now));
  send_json(c, job->client, reply);
  c->queue_head = (c->queue_head + 1u) % EMU_CONTROL_QUEUE;
  c->queue_count--;
}

static void progress_send(emu_control_t *c) {
  if (c->sending) {
    if (reply_over(c)) {
      finish_send(c);
    }
    return;
  }
  if (c->queue_count == 0) {
    return;
  }
  const sim_cycles_t now = c->world->now;
  if (c->world->bus.pending_total == 0 && now >= bus_last_activity(&c->world->bus) + sim_us(IDLE_BEFORE_SEND_US)) {
    start_send(c);
  }
}

sim_cycles_t emu_control_next_event(const emu_control_t *c) {
  if (!c->sending && c->queue_count == 0) {
    return SIM_CYCLES_NEVER;
  }
  return c->world->now + sim_us(50); /* poll the exchange every 50 us of simulated time */
}

/* ---- requests -------------------------------------------------------------------------- */

/* ---- packets of the bus monitor ------------------------------------------------------- */

static void hex_bytes(const uint8_t *bytes, size_t n, char *out, size_t len) {
  size_t used = 0;
  out[0] = '\0';
  for (size_t i = 0; i < n && used + 4u <= len; i++) {
    used += (size_t)snprintf(out + used, len - used, i ? " %02X" : "%02X", bytes[i]);
  }
}

/* A listener of the monitor (on the simulation thread, between the serve loop's polls). */
static void on_packet(void *ctx, const bus_packet_t *p) {
  emu_control_t *c = ctx;
  if (c->batch_count >= EMU_CONTROL_BATCH_MAX) {
    c->packets_dropped++;
    return;
  }
  cJSON *j = cJSON_CreateObject();
  cJSON_AddNumberToObject(j, "time_us", sim_cycles_to_us(p->start));
  cJSON_AddNumberToObject(j, "end_us", sim_cycles_to_us(p->end));
  cJSON_AddStringToObject(j, "sender", p->sender_name);
  cJSON_AddStringToObject(j, "kind", bus_packet_kind_name(p->kind));
  char hex[3u * BUS_MONITOR_MAX_RAW + 1u];
  if (p->kind == BUS_PACKET_INSTRUCTION || p->kind == BUS_PACKET_STATUS) {
    cJSON_AddNumberToObject(j, "id", p->id);
    cJSON_AddNumberToObject(j, "code", p->code);
    if (p->kind == BUS_PACKET_INSTRUCTION) {
      const char *name = bus_packet_instruction_name(p->code);
      cJSON_AddStringToObject(j, "instruction_name", name ? name : "UNKNOWN");
    } else {
      cJSON_AddNumberToObject(j, "error", p->code);
    }
    hex_bytes(p->params, p->param_count, hex, sizeof hex);
    cJSON_AddStringToObject(j, "params", hex);
    cJSON_AddBoolToObject(j, "checksum_ok", p->checksum_ok);
  }
  cJSON_AddBoolToObject(j, "collision", p->collision);
  hex_bytes(p->raw, p->raw_count, hex, sizeof hex);
  cJSON_AddStringToObject(j, "raw", hex);
  if (!c->batch) {
    c->batch = cJSON_CreateArray();
  }
  cJSON_AddItemToArray(c->batch, j);
  c->batch_count++;
}

static bool anyone_wants_packets(const emu_control_t *c) {
  for (unsigned i = 0; i < CONTROL_MAX_CLIENTS; i++) {
    if (c->with_packets[i] && control_socket_connected(&c->socket, i)) {
      return true;
    }
  }
  return false;
}

/* Listens to the monitor while anyone subscribes to packets: --log-bus's, or one made for
 * that (and removed again when the last subscriber goes, so the bus has no tap then). */
static void update_packet_listener(emu_control_t *c) {
  const bool wanted = anyone_wants_packets(c);
  bus_monitor_t *monitor = *c->shared_monitor ? *c->shared_monitor : c->own_monitor;
  if (wanted && c->listener < 0) {
    if (!monitor) {
      monitor = c->own_monitor = bus_monitor_create(&c->world->bus, sim_us(BUS_MONITOR_DEFAULT_GAP_US));
      if (!monitor) {
        return;
      }
      bus_monitor_set_client(monitor, c->client_node);
      bus_monitor_add_master(monitor, c->master->node);
    }
    c->listener = bus_monitor_add_listener(monitor, on_packet, c);
  } else if (!wanted && c->listener >= 0) {
    bus_monitor_remove_listener(monitor, c->listener);
    c->listener = -1;
    if (c->own_monitor) {
      bus_monitor_destroy(c->own_monitor);
      c->own_monitor = NULL;
    }
  }
}

static void push_packets(emu_control_t *c, double wall) {
  if (c->own_monitor) {
    bus_monitor_flush(c->own_monitor, c->world->now);
  }
  if (!c->batch || wall < c->batch_due_us) {
    return;
  }
  c->batch_due_us = wall + PACKET_BATCH_PERIOD_US;
  cJSON *event = cJSON_CreateObject();
  cJSON_AddStringToObject(event, "event", "packets");
  cJSON_AddItemToObject(event, "packets", c->batch);
  cJSON_AddNumberToObject(event, "dropped", (double)c->packets_dropped);
  c->batch = NULL;
  c->batch_count = 0;
  char *text = cJSON_PrintUnformatted(event);
  cJSON_Delete(event);
  if (!text) {
    return;
  }
  for (unsigned i = 0; i < CONTROL_MAX_CLIENTS; i++) {
    if (c->with_packets[i]) {
      control_socket_send(&c->socket, i, text);
    }
  }
  free(text);
}

static void handle_subscribe(emu_control_t *c, unsigned client, const cJSON *req) {
  const cJSON *hz = cJSON_GetObjectItemCaseSensitive(req, "telemetry_hz");
  if (!cJSON_IsNumber(hz) || hz->valuedouble < 0.0 || hz->valuedouble > TELEMETRY_HZ_MAX) {
    send_error(c, client, "subscribe", "\"telemetry_hz\" must be 0 (stop) .. 100");
    return;
  }
  c->period_us[client] = hz->valuedouble > 0.0 ? 1e6 / hz->valuedouble : 0.0;
  c->due_us[client] = pacing_wall_us();
  c->with_table[client] = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(req, "table"));
  /* "table_hz": tables in only some events (a page redraws its table a few times a second) */
  const cJSON *table_hz = cJSON_GetObjectItemCaseSensitive(req, "table_hz");
  c->table_period_us[client] = 0.0;
  if (cJSON_IsNumber(table_hz) && table_hz->valuedouble > 0.0) {
    c->with_table[client] = true;
    c->table_period_us[client] = 1e6 / table_hz->valuedouble;
  }
  c->table_due_us[client] = 0.0;
  c->with_packets[client] = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(req, "packets"));
  update_packet_listener(c);
  cJSON *reply = cJSON_CreateObject();
  cJSON_AddBoolToObject(reply, "ok", true);
  cJSON_AddStringToObject(reply, "op", "subscribe");
  send_json(c, client, reply);
}

static void on_line(void *ctx, control_socket_t *cs, unsigned client, char *line) {
  (void)cs;
  emu_control_t *c = ctx;
  if (line == NULL) {
    send_error(c, client, NULL, "request line too long");
    return;
  }
  if (line[0] == '\0') {
    return;
  }
  cJSON *req = cJSON_Parse(line);
  const cJSON *op = cJSON_GetObjectItemCaseSensitive(req, "op");
  if (!cJSON_IsObject(req) || !cJSON_IsString(op)) {
    send_error(c, client, NULL, "a request is one JSON object with \"op\" per line");
  } else if (strcmp(op->valuestring, "status") == 0) {
    const bool table = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(req, "table"));
    send_json(c, client, status_json(c, false, table));
  } else if (strcmp(op->valuestring, "world") == 0) {
    handle_world(c, client, req);
  } else if (strcmp(op->valuestring, "send") == 0) {
    handle_send(c, client, req);
  } else if (strcmp(op->valuestring, "subscribe") == 0) {
    handle_subscribe(c, client, req);
  } else {
    send_error(c, client, op->valuestring, "unknown op (status, world, send, subscribe)");
  }
  cJSON_Delete(req);
}

static void push_telemetry(emu_control_t *c) {
  const double wall = pacing_wall_us();
  for (unsigned i = 0; i < CONTROL_MAX_CLIENTS; i++) {
    if (!control_socket_connected(&c->socket, i)) {
      c->period_us[i] = 0.0;
      c->with_packets[i] = false;
      continue;
    }
    if (c->period_us[i] <= 0.0 || wall < c->due_us[i]) {
      continue;
    }
    c->due_us[i] += c->period_us[i];
    if (c->due_us[i] < wall) {
      c->due_us[i] = wall + c->period_us[i]; /* fell behind: no burst to catch up */
    }
    bool table = c->with_table[i];
    if (table && c->table_period_us[i] > 0.0) {
      table = wall >= c->table_due_us[i];
      if (table) {
        c->table_due_us[i] = wall + c->table_period_us[i];
      }
    }
    send_json(c, i, status_json(c, true, table));
  }
}

int emu_control_open(emu_control_t *c, const char *path, world_t *world, pty_bridge_t *pty,
                     plant_options_t *worlds, const uint8_t *slot_ids, const char *elf_path,
                     bus_monitor_t **monitor, char *err, size_t err_len) {
  memset(c, 0, sizeof(*c));
  c->shared_monitor = monitor;
  c->listener = -1;
  c->client_node = pty->node;
  c->world = world;
  c->pty = pty;
  c->worlds = worlds;
  c->slot_ids = slot_ids;
  servo_probe_locate(elf_path, &c->map);
  c->master = world_add_master(world, pty->actual_bps); /* the client's baud: no shorter bus lookahead */
  if (!c->master) {
    snprintf(err, err_len, "control socket: no room on the bus for its master");
    return -1;
  }
  /* Named for the bus monitor and --log-bus, whose instruction packets it sends. */
  snprintf(world->bus.nodes[c->master->node].name, sizeof(world->bus.nodes[c->master->node].name), "control");
  if (*monitor) {
    bus_monitor_add_master(*monitor, c->master->node);
  }
  if (control_socket_open(&c->socket, path, err, err_len) != 0) {
    return -1;
  }
  c->socket.on_line = on_line;
  c->socket.ctx = c;
  return 0;
}

void emu_control_close(emu_control_t *c) {
  if (c->sending) {
    pty_bridge_hold(c->pty, false);
  }
  memset(c->with_packets, 0, sizeof(c->with_packets));
  update_packet_listener(c);
  cJSON_Delete(c->batch);
  c->batch = NULL;
  control_socket_close(&c->socket);
}

void emu_control_poll(emu_control_t *c) {
  const double wall = pacing_wall_us();
  if (!c->sending && c->queue_count == 0) {
    if (wall < c->next_poll_us) {
      return;
    }
    master_rx_clear(c->master); /* it hears every byte on the bus: keep none while idle */
  }
  c->next_poll_us = wall + POLL_PERIOD_US;
  control_socket_poll(&c->socket);
  progress_send(c);
  push_telemetry(c);
  update_packet_listener(c); /* a subscriber may have gone */
  push_packets(c, wall);
  control_socket_poll(&c->socket); /* what the above queued goes out now */
}
