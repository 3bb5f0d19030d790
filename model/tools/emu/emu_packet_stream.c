/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_packet_stream.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <string.h>

#include "bus_packet_text.h"

static void hex_bytes(const uint8_t *bytes, size_t n, char *out, size_t len) {
  size_t used = 0;
  out[0] = '\0';
  for (size_t i = 0; i < n && used + 4u <= len; i++) {
    used += (size_t)snprintf(out + used, len - used, i ? " %02X" : "%02X", bytes[i]);
  }
}

/* A listener of the monitor (on the simulation thread, between the serve loop's polls). */
static void on_packet(void *ctx, const bus_packet_t *p) {
  emu_packet_stream_t *s = ctx;
  if (s->batch_count >= EMU_PACKET_STREAM_BATCH_MAX) {
    s->dropped++;
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
  if (!s->batch) {
    s->batch = cJSON_CreateArray();
  }
  cJSON_AddItemToArray(s->batch, j);
  s->batch_count++;
}

void emu_packet_stream_init(emu_packet_stream_t *s, bus_t *bus, bus_monitor_t **shared, int client_node,
                            int master_node) {
  memset(s, 0, sizeof(*s));
  s->bus = bus;
  s->shared = shared;
  s->listener = -1;
  s->client_node = client_node;
  s->master_node = master_node;
  if (*shared) {
    bus_monitor_add_master(*shared, master_node);
  }
}

void emu_packet_stream_want(emu_packet_stream_t *s, bool wanted) {
  bus_monitor_t *monitor = *s->shared ? *s->shared : s->own;
  if (wanted && s->listener < 0) {
    if (!monitor) {
      monitor = s->own = bus_monitor_create(s->bus, sim_us(BUS_MONITOR_DEFAULT_GAP_US));
      if (!monitor) {
        return;
      }
      bus_monitor_set_client(monitor, s->client_node);
      bus_monitor_add_master(monitor, s->master_node);
    }
    s->listener = bus_monitor_add_listener(monitor, on_packet, s);
  } else if (!wanted && s->listener >= 0) {
    bus_monitor_remove_listener(monitor, s->listener);
    s->listener = -1;
    if (s->own) {
      bus_monitor_destroy(s->own);
      s->own = NULL;
    }
  }
}

char *emu_packet_stream_take(emu_packet_stream_t *s, double wall_us, sim_cycles_t now) {
  if (s->own) {
    bus_monitor_flush(s->own, now);
  }
  if (!s->batch || wall_us < s->due_us) {
    return NULL;
  }
  s->due_us = wall_us + EMU_PACKET_STREAM_PERIOD_US;
  cJSON *event = cJSON_CreateObject();
  cJSON_AddStringToObject(event, "event", "packets");
  cJSON_AddItemToObject(event, "packets", s->batch);
  cJSON_AddNumberToObject(event, "dropped", (double)s->dropped);
  s->batch = NULL;
  s->batch_count = 0;
  char *text = cJSON_PrintUnformatted(event);
  cJSON_Delete(event);
  return text;
}

void emu_packet_stream_close(emu_packet_stream_t *s) {
  emu_packet_stream_want(s, false);
  cJSON_Delete(s->batch);
  s->batch = NULL;
}
