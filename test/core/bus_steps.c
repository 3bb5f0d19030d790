#include "bus_steps.h"

#include <dirent.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "conformance_log.h"
#include "packet_encode.h"
#include "dxl_protocol.h"

void given_bus(host_bus_t *bus, uint8_t id) { given_bus_of(bus, &id, 1); }

void given_bus_of(host_bus_t *bus, const uint8_t *ids, size_t count) {
  host_bus_init(bus, ids, count, CONV_DEFAULT_BAUD, CONV_DEFAULT_TEMPERATURE_C);
}

void when_master_sends(host_bus_t *bus, uint8_t id, uint8_t instruction, const uint8_t *params, size_t count) {
  uint8_t packet[STEPS_PACKET_MAX];
  assert_true(count <= 253u);
  const size_t length = packet_encode(packet, id, instruction, params, count);
  host_bus_send(bus, packet, length);
}

void when_master_sends_bytes(host_bus_t *bus, const uint8_t *bytes, size_t count) {
  host_bus_send(bus, bytes, count);
}

void then_heard_bytes(const host_bus_t *bus, const uint8_t *bytes, size_t count) {
  if (bus->heard_len != count || (count != 0 && memcmp(bus->heard, bytes, count) != 0)) {
    char want[1024];
    char got[1024];
    fail_msg("expected %s, heard %s", packet_hex(bytes, count, want, sizeof want),
             packet_hex(bus->heard, bus->heard_len, got, sizeof got));
  }
  assert_false(bus->collision);
}

void then_status_is(const host_bus_t *bus, uint8_t id, uint8_t error, const uint8_t *params, size_t count) {
  uint8_t packet[STEPS_PACKET_MAX];
  const size_t length = packet_encode(packet, id, error, params, count);
  then_heard_bytes(bus, packet, length);
}

void then_silence(const host_bus_t *bus) { then_heard_bytes(bus, NULL, 0); }

void given_write(host_bus_t *bus, uint8_t id, uint8_t addr, const uint8_t *data, size_t count) {
  uint8_t params[STEPS_PACKET_MAX];
  params[0] = addr;
  memcpy(&params[1], data, count);
  conformance_given_begin(); /* recorded as setup */
  when_master_sends(bus, id, DXL_INST_WRITE, params, count + 1u);
  conformance_given_end();
}

dxl_servo_t *servo_of(host_bus_t *bus, uint8_t id) {
  host_bus_servo_t *hs = host_bus_find(bus, id);
  if (hs == NULL) {
    fail_msg("no servo with ID %u on the bus", id);
  }
  return &hs->servo;
}

uint8_t table_byte(host_bus_t *bus, uint8_t id, uint8_t addr) { return servo_of(bus, id)->table[addr]; }

uint16_t table_word(host_bus_t *bus, uint8_t id, uint8_t addr) {
  const uint8_t *t = servo_of(bus, id)->table;
  return (uint16_t)(t[addr] | (t[addr + 1] << 8));
}

void conv_bus_init(host_bus_t *bus, const conv_t *conv) {
  host_bus_init(bus, conv->servo_ids, conv->servo_count, conv->baud, conv->temperature_c);
}

bool conv_replay_step(host_bus_t *bus, const conv_t *conv, const conv_step_t *step, char *msg, size_t msg_len) {
  switch (step->kind) {
  case CONV_STEP_MASTER_BAUD:
    host_bus_set_master_baud(bus, step->master_baud);
    return true;
  case CONV_STEP_POWER_CYCLE:
    host_bus_power_cycle(bus);
    return true;
  case CONV_STEP_EXCHANGE:
  default:
    break;
  }
  host_bus_send(bus, step->send, step->send_len);
  const bool same = bus->heard_len == step->expect_len &&
                    (step->expect_len == 0 || memcmp(bus->heard, step->expect, step->expect_len) == 0);
  if (same && !bus->collision) {
    return true;
  }
  char sent[1024];
  char want[1024];
  char got[1024];
  snprintf(msg, msg_len, "%s:%u: sent %s\n  expected %s\n  heard    %s%s", conv->path,
           step->expect_line != 0 ? step->expect_line : step->line, packet_hex(step->send, step->send_len, sent, sizeof sent),
           packet_hex(step->expect, step->expect_len, want, sizeof want), packet_hex(bus->heard, bus->heard_len, got, sizeof got),
           bus->collision ? " (replies collided)" : "");
  return false;
}

static int compare_names(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

size_t conv_list_files(const char *dir_path, char **paths, size_t max, size_t path_chars) {
  DIR *dir = opendir(dir_path);
  if (dir == NULL) {
    return 0;
  }
  size_t count = 0;
  struct dirent *entry;
  while ((entry = readdir(dir)) != NULL && count < max) {
    const size_t n = strlen(entry->d_name);
    if (n > 5 && strcmp(entry->d_name + n - 5, ".conv") == 0) {
      paths[count] = malloc(path_chars);
      if (paths[count] == NULL) {
        break;
      }
      snprintf(paths[count], path_chars, "%s/%s", dir_path, entry->d_name);
      count++;
    }
  }
  closedir(dir);
  qsort(paths, count, sizeof paths[0], compare_names);
  return count;
}
