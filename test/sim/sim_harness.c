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

#include "packet_build.h"

#ifndef AX12_FIRMWARE_DIR
#error "AX12_FIRMWARE_DIR must be defined by the build"
#endif
#ifndef AX12_FIRMWARE_REQUIRED
#define AX12_FIRMWARE_REQUIRED 1
#endif

const char *harness_elf_path(const char *profile, const char *mcu) {
  static char path[1024];
  snprintf(path, sizeof(path), "%s/ax12-%s-%s.elf", AX12_FIRMWARE_DIR, profile, mcu);
  return path;
}

void harness_open(harness_t *h, const char *profile, const char *mcu, unsigned master_baud) {
  memset(h, 0, sizeof(*h));
  snprintf(h->elf, sizeof(h->elf), "%s", harness_elf_path(profile, mcu));
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
  h->master = master_create(h->world, sim_baud_reg_to_bps(master_baud));
  assert_non_null(h->master);
}

void harness_close(harness_t *h) {
  /* Every byte reached every MCU at its exact end cycle (the stepping contract held). */
  for (size_t i = 0; i < h->world->servo_count; i++) {
    assert_int_equal(h->world->servos[i]->board.link.rx_late, 0);
  }
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
  const sim_cycles_t limit = h->world->now + sim_ms(1000);
  for (;;) {
    bool all = true;
    for (size_t i = 0; i < h->world->servo_count; i++) {
      all &= servo_listening(h->world->servos[i]);
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
  for (size_t i = 0; i < h->world->servo_count; i++) {
    servo_power_cycle(h->world->servos[i]);
  }
  harness_boot(h, 5);
}

size_t harness_packet(uint8_t *out, uint8_t id, uint8_t instruction, const uint8_t *params, size_t count) {
  return packet_build(out, id, instruction, params, count);
}

size_t harness_exchange(harness_t *h, const uint8_t *bytes, size_t count, size_t expect, uint8_t *reply,
                        size_t reply_max) {
  world_t *w = h->world;
  master_t *m = h->master;
  master_rx_clear(m);
  const sim_cycles_t sent_end = master_send(m, bytes, count);
  world_run_until(w, sent_end);
  const sim_cycles_t step = sim_us(50);
  if (expect == 0) {
    world_run_until(w, sent_end + sim_ms(HARNESS_SILENCE_MS));
  } else {
    const sim_cycles_t limit = sent_end + sim_ms(HARNESS_REPLY_TIMEOUT_MS);
    while (w->now < limit && master_rx_count(m) < expect) {
      world_run_until(w, w->now + step);
    }
    /* Then until the line has been quiet for a while (more bytes than expected count). */
    for (;;) {
      const size_t n = master_rx_count(m);
      const sim_cycles_t last = n ? master_rx(m, n - 1u)->end : sent_end;
      if (w->now >= last + sim_us(HARNESS_QUIET_US) || w->now >= limit + sim_ms(10)) {
        break;
      }
      world_run_until(w, w->now + step);
    }
  }
  return master_rx_values(m, reply, reply_max);
}

size_t harness_request(harness_t *h, uint8_t id, uint8_t instruction, const uint8_t *params, size_t count,
                       size_t reply_len, uint8_t *reply) {
  uint8_t packet[300];
  const size_t n = harness_packet(packet, id, instruction, params, count);
  uint8_t scratch[HARNESS_MAX_REPLY];
  return harness_exchange(h, packet, n, reply_len, reply ? reply : scratch, HARNESS_MAX_REPLY);
}

const char *harness_hex(const uint8_t *bytes, size_t count, char *text, size_t text_len) {
  return packet_hex(bytes, count, text, text_len);
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
