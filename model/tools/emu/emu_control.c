/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_control.h"

#include <cjson/cJSON.h>
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "emu_robot.h"
#include "emu_world_request.h"
#include "pacing.h"

#define TELEMETRY_HZ_MAX 100.0
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

/* ---- send: a packet on the bus (emu_bus_master.h) -------------------------------------- */

/* "FF FF 01 02 01 FB", "ffff010201fb" or an array of numbers. */
static bool parse_bytes(const cJSON *value, uint8_t *out, size_t *len) {
  *len = 0;
  if (cJSON_IsArray(value)) {
    const cJSON *v;
    cJSON_ArrayForEach(v, value) {
      if (!cJSON_IsNumber(v) || v->valuedouble < 0 || v->valuedouble > 255 || v->valuedouble != (int)v->valuedouble ||
          *len == EMU_BUS_MASTER_PACKET_MAX) {
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
      if (*len == EMU_BUS_MASTER_PACKET_MAX) {
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
  uint8_t bytes[EMU_BUS_MASTER_PACKET_MAX];
  size_t len = 0;
  char err[160];
  if (!parse_bytes(cJSON_GetObjectItemCaseSensitive(req, "bytes"), bytes, &len)) {
    send_error(c, client, "send", "\"bytes\" must be hex digits (\"FF FF 01 02 01 FB\") or an array of 0..255");
    return;
  }
  if (!valid_instruction_packet(bytes, len, err, sizeof err)) {
    send_error(c, client, "send", err);
    return;
  }
  if (!emu_bus_master_queue(&c->master, client, bytes, len)) {
    send_error(c, client, "send", "too many packets waiting for the bus");
  }
}

/* The reply to a "send", to the client that asked. */
static void on_exchange_done(void *ctx, unsigned client, const uint8_t *reply, size_t count) {
  emu_control_t *c = ctx;
  char hex[3u * EMU_BUS_MASTER_PACKET_MAX + 1u] = "";
  size_t used = 0;
  for (size_t i = 0; i < count; i++) {
    used += (size_t)snprintf(hex + used, sizeof hex - used, i ? " %02X" : "%02X", reply[i]);
  }
  cJSON *answer = cJSON_CreateObject();
  cJSON_AddBoolToObject(answer, "ok", true);
  cJSON_AddStringToObject(answer, "op", "send");
  cJSON_AddStringToObject(answer, "reply", hex);
  cJSON_AddNumberToObject(answer, "time_us", sim_cycles_to_us(c->servos.world->now));
  send_json(c, client, answer);
}

sim_cycles_t emu_control_next_event(const emu_control_t *c) {
  return emu_bus_master_busy(&c->master) ? c->servos.world->now + sim_us(EMU_BUS_MASTER_POLL_US) : SIM_CYCLES_NEVER;
}

/* ---- subscriptions --------------------------------------------------------------------- */

static bool anyone_wants_packets(const emu_control_t *c) {
  for (unsigned i = 0; i < CONTROL_MAX_CLIENTS; i++) {
    if (c->with_packets[i] && control_socket_connected(&c->socket, i)) {
      return true;
    }
  }
  return false;
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
  c->without_robot[client] = cJSON_IsFalse(cJSON_GetObjectItemCaseSensitive(req, "robot"));
  /* "servos": [slots]: telemetry of those servos only (a page's charts of the one it shows) */
  const cJSON *slots = cJSON_GetObjectItemCaseSensitive(req, "servos");
  c->filtered[client] = cJSON_IsArray(slots);
  memset(c->only_slots[client], 0, sizeof(c->only_slots[client]));
  const cJSON *slot;
  cJSON_ArrayForEach(slot, slots) {
    if (cJSON_IsNumber(slot) && slot->valuedouble >= 0 && slot->valuedouble < 256) {
      c->only_slots[client][(int)slot->valuedouble] = true;
    }
  }
  emu_packet_stream_want(&c->packets, anyone_wants_packets(c));
  cJSON *reply = cJSON_CreateObject();
  cJSON_AddBoolToObject(reply, "ok", true);
  cJSON_AddStringToObject(reply, "op", "subscribe");
  send_json(c, client, reply);
}

static void push_telemetry(emu_control_t *c, double wall) {
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
    send_json(c, i, emu_status_json(&c->servos, true, table, c->filtered[i] ? c->only_slots[i] : NULL,
                                    !c->without_robot[i]));
  }
}

static void push_packets(emu_control_t *c, double wall) {
  emu_packet_stream_want(&c->packets, anyone_wants_packets(c)); /* a subscriber may have gone */
  char *text = emu_packet_stream_take(&c->packets, wall, c->servos.world->now);
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

/* ---- requests -------------------------------------------------------------------------- */

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
    cJSON *status = emu_status_json(&c->servos, false, table, NULL, true);
    cJSON_AddStringToObject(status, "device", c->device);
    send_json(c, client, status);
  } else if (strcmp(op->valuestring, "world") == 0) {
    char err[256];
    cJSON *answer = emu_world_request(&c->servos, req, err, sizeof err);
    if (answer) {
      send_json(c, client, answer);
    } else {
      send_error(c, client, "world", err);
    }
  } else if (strcmp(op->valuestring, "robot") == 0) {
    char err[256];
    cJSON *answer = c->servos.robot ? emu_robot_request(c->servos.robot, req, err, sizeof err) : NULL;
    if (answer) {
      send_json(c, client, answer);
    } else {
      send_error(c, client, "robot", c->servos.robot ? err : "no robot: the emulator runs without --robot");
    }
  } else if (strcmp(op->valuestring, "send") == 0) {
    handle_send(c, client, req);
  } else if (strcmp(op->valuestring, "subscribe") == 0) {
    handle_subscribe(c, client, req);
  } else {
    send_error(c, client, op->valuestring, "unknown op (status, world, robot, send, subscribe)");
  }
  cJSON_Delete(req);
}

int emu_control_open(emu_control_t *c, const char *path, world_t *world, world_robot_t *robot, pty_bridge_t *pty,
                     plant_options_t *worlds, const uint8_t *slot_ids, const char *elf_path,
                     bus_monitor_t **monitor, char *err, size_t err_len) {
  memset(c, 0, sizeof(*c));
  c->servos = (emu_servos_t){.world = world, .worlds = worlds, .slot_ids = slot_ids, .robot = robot};
  c->device = pty->device;
  servo_probe_locate(elf_path, &c->servos.map);
  if (emu_bus_master_open(&c->master, world, pty, &c->servos.map) != 0) {
    snprintf(err, err_len, "control socket: no room on the bus for its master");
    return -1;
  }
  emu_packet_stream_init(&c->packets, &world->bus, monitor, pty->node, c->master.master->node);
  if (control_socket_open(&c->socket, path, err, err_len) != 0) {
    return -1;
  }
  c->socket.on_line = on_line;
  c->socket.ctx = c;
  return 0;
}

void emu_control_show_timing(emu_control_t *c, const pacing_t *pacing, const pty_bridge_t *pty,
                             const emu_realtime_t *realtime) {
  c->servos.pacing = pacing;
  c->servos.pty = pty;
  c->servos.realtime = realtime;
}

void emu_control_close(emu_control_t *c) {
  emu_bus_master_close(&c->master);
  emu_packet_stream_close(&c->packets);
  control_socket_close(&c->socket);
}

void emu_control_poll(emu_control_t *c) {
  const double wall = pacing_wall_us();
  if (!emu_bus_master_busy(&c->master)) {
    if (wall < c->next_poll_us) {
      return;
    }
    emu_bus_master_forget(&c->master);
  }
  c->next_poll_us = wall + POLL_PERIOD_US;
  control_socket_poll(&c->socket);
  emu_bus_master_poll(&c->master, on_exchange_done, c);
  push_telemetry(c, wall);
  push_packets(c, wall);
  control_socket_poll(&c->socket); /* what the above queued goes out now */
}
