/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "bench_rig.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <sim_avr.h>

#include "dxl_protocol.h"
#include "elf_symbols.h"

const char *bench_elf_path;

/* Polled every 5 us; after the reply, 200 us of quiet line before the next request. */
static const master_wait_t bench_wait = {.poll_step = US(5),
                                         .reply_timeout = REPLY_TIMEOUT,
                                         .quiet_after = US(200),
                                         .talk_limit = US(200),
                                         .silence = REPLY_TIMEOUT};

double bench_wall_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + (double)t.tv_nsec / 1e9;
}

void bench_die(const char *what, const char *detail) {
  fprintf(stderr, "ax12-bench: %s%s%s\n", what, detail ? ": " : "", detail ? detail : "");
  exit(1);
}

void bench_rig_create(bench_rig_t *r, const uint8_t *ids, size_t count) {
  char err[512];
  r->world = world_create(bench_elf_path, strstr(bench_elf_path, "atmega328p") ? "atmega328p" : "atmega88",
                          strstr(bench_elf_path, "ax12a-") ? EEPROM_PROFILE_AX12A : EEPROM_PROFILE_AX12, err,
                          sizeof err);
  if (!r->world) bench_die("cannot load the firmware", err);
  for (size_t i = 0; i < count; i++) {
    if (!world_add_servo(r->world, ids[i], 1, NULL, err, sizeof err)) bench_die("cannot add a servo", err);
  }
  r->master = world_add_master(r->world, 1e6);
  if (!r->master) bench_die("cannot add the master", NULL);
  r->requester = world_requester(r->world, r->master, bench_wait);
}

void bench_rig_power_up(bench_rig_t *r) {
  world_run_until(r->world, r->world->now + MS(300)); /* power-up: LED blinks, ADC settles */
}

void bench_rig_open(bench_rig_t *r, unsigned servos) {
  uint8_t ids[256];
  for (unsigned id = 1; id <= servos; id++) {
    ids[id - 1u] = (uint8_t)id;
  }
  bench_rig_create(r, ids, servos);
  bench_rig_power_up(r);
}

void bench_rig_close(bench_rig_t *r) {
  master_destroy(r->master);
  world_destroy(r->world);
}

sim_cycles_t bench_exchange(bench_rig_t *r, const uint8_t *bytes, size_t count, size_t expect_bytes) {
  uint8_t ignored[1];
  const master_reply_t reply = master_exchange(&r->requester, bytes, count, expect_bytes, ignored, 0);
  return reply.reply_start != SIM_CYCLES_NEVER ? reply.reply_start - reply.request_end : 0;
}

void bench_write_byte(bench_rig_t *r, uint8_t id, uint8_t addr, uint8_t value) {
  uint8_t p[8], params[2] = {addr, value};
  if (bench_exchange(r, p, packet_encode(p, id, DXL_INST_WRITE, params, 2), 6) == 0) bench_die("no reply to a WRITE", NULL);
}

long bench_firmware_counter(const servo_t *s, const char *symbol, unsigned bytes) {
  uint32_t address;
  if (!elf_symbol_address(bench_elf_path, symbol, &address)) return -1;
  long value = 0;
  for (unsigned i = 0; i < bytes; i++) value |= (long)s->avr->data[address + i] << (8 * i);
  return value;
}
