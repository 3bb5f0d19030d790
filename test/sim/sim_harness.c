/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "sim_harness.h"

#include <dirent.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmocka.h>

#include "master_request.h"

#ifndef AX12_FIRMWARE_DIR
#error "AX12_FIRMWARE_DIR must be defined by the build"
#endif
#ifndef AX12_FIRMWARE_REQUIRED
#define AX12_FIRMWARE_REQUIRED 1
#endif

/* Polled every 50 us; see sim_harness.h for the bounds. */
static const master_wait_t harness_wait = {.poll_step = 50u * SIM_CYCLES_PER_US,
                                           .reply_timeout = HARNESS_REPLY_TIMEOUT_MS * 1000u * SIM_CYCLES_PER_US,
                                           .quiet_after = HARNESS_QUIET_US * SIM_CYCLES_PER_US,
                                           .talk_limit = 10000u * SIM_CYCLES_PER_US,
                                           .silence = HARNESS_SILENCE_MS * 1000u * SIM_CYCLES_PER_US};

const char *harness_elf_path(const char *profile, const char *mcu) {
  static char path[1024];
  snprintf(path, sizeof(path), "%s/ax12-%s-%s.elf", AX12_FIRMWARE_DIR, profile, mcu);
  return path;
}

void harness_open(harness_t *h, const char *profile, const char *mcu, unsigned master_baud) {
  harness_open_elf(h, harness_elf_path(profile, mcu), profile, mcu, master_baud);
}

void harness_open_elf(harness_t *h, const char *elf, const char *profile, const char *mcu, unsigned master_baud) {
  memset(h, 0, sizeof(*h));
  snprintf(h->elf, sizeof(h->elf), "%s", elf);
  if (access(h->elf, R_OK) != 0) {
    if (!AX12_FIRMWARE_REQUIRED) {
      fprintf(stderr, "skipped: no firmware ELF %s\n", h->elf);
      skip();
    }
    fail_msg("firmware ELF missing: %s", h->elf);
  }
  eeprom_profile_t p;
  assert_true(eeprom_profile_parse(profile, &p));
  char err[512];
  h->world = world_create(h->elf, mcu, p, err, sizeof(err));
  if (!h->world) {
    fail_msg("%s", err);
  }
  h->master = world_add_master(h->world, sim_baud_reg_to_bps(master_baud));
  assert_non_null(h->master);
  h->requester = world_requester(h->world, h->master, harness_wait);
}

void harness_close(harness_t *h) {
  /* Every byte reached every MCU at its exact end cycle (the stepping contract held). */
  for (size_t i = 0; i < h->world->servo_count; i++) {
    assert_int_equal(h->world->servos[i]->board.link.rx_late, 0);
  }
  /* A clean stop, as the emulator's on SIGTERM: EEPROM writes under way are finished first
   * (tests of power cuts capture the EEPROM instead of closing). */
  assert_int_equal(world_settle_and_persist(h->world, sim_ms(HARNESS_SETTLE_MS)), 0);
  master_destroy(h->master);
  world_destroy(h->world);
  memset(h, 0, sizeof(*h));
}

servo_t *harness_add_servo(harness_t *h, uint8_t id, uint8_t baud_reg, const char *state_dir) {
  char err[512];
  char path[4096];
  if (state_dir) {
    eeprom_store_path(path, sizeof(path), state_dir, id);
  }
  servo_t *s = world_add_servo(h->world, id, baud_reg, state_dir ? path : NULL, err, sizeof(err));
  if (!s) {
    fail_msg("%s", err);
  }
  return s;
}

void harness_boot(harness_t *h, unsigned settle_ms) {
  const sim_cycles_t powered_at = h->world->now;
  const sim_cycles_t limit = h->world->now + sim_ms(1000);
  for (;;) {
    bool all = true;
    for (size_t i = 0; i < h->world->servo_count; i++) {
      all &= servo_ready_for_clients(h->world->servos[i], h->world->now - powered_at);
    }
    if (all) {
      break;
    }
    if (h->world->now >= limit) {
      fail_msg("the servos did not enable their UART within 1 s");
    }
    world_run_until(h->world, h->world->now + sim_us(100));
  }
  world_run_until(h->world, h->world->now + sim_ms(settle_ms));
}

void harness_power_cycle(harness_t *h) {
  /* Switched off once the EEPROM writes under way have finished, as a person would (a cut in
   * the middle of one: sim_power_cut). */
  assert_int_equal(world_settle_and_persist(h->world, sim_ms(HARNESS_SETTLE_MS)), 0);
  for (size_t i = 0; i < h->world->servo_count; i++) {
    servo_power_cycle(h->world->servos[i]);
  }
  harness_boot(h, 5);
}

size_t harness_exchange(harness_t *h, const uint8_t *bytes, size_t count, size_t expect, uint8_t *reply,
                        size_t reply_max) {
  return master_exchange(&h->requester, bytes, count, expect, reply, reply_max).received;
}

size_t harness_request(harness_t *h, uint8_t id, uint8_t instruction, const uint8_t *params, size_t count,
                       size_t reply_len, uint8_t *reply) {
  uint8_t scratch[HARNESS_MAX_REPLY];
  return master_request(&h->requester, id, instruction, params, count, reply_len, reply ? reply : scratch,
                        HARNESS_MAX_REPLY)
      .received;
}

void harness_tempdir(char *out, size_t len) {
  snprintf(out, len, "/tmp/ax12-simtest-XXXXXX");
  if (!mkdtemp(out)) {
    fail_msg("mkdtemp failed");
  }
}

void harness_rmdir(const char *dir) {
  DIR *d = opendir(dir);
  if (!d) {
    return;
  }
  struct dirent *e;
  char path[4096];
  while ((e = readdir(d)) != NULL) {
    if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) {
      continue;
    }
    snprintf(path, sizeof(path), "%s/%s", dir, e->d_name);
    unlink(path);
  }
  closedir(d);
  rmdir(dir);
}
