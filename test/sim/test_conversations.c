/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The conversation suite (test/conversations/ (every .conv file)) replayed over the simulated wire into
 * the firmware ELF: byte-identical replies. Every file runs against the ELF of each profile it
 * applies to, at the baud it asks for (1 Mbps, or e.g. `baud 34`: 57 143 bit/s); the suite
 * also runs once more at Baud Rate 34 for the files that leave the baud alone, so every
 * scenario is checked at a slow baud too. The master talks at the servos' baud. */
#include <dirent.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "conversation.h"
#include "sim_harness.h"

#define MAX_FILES 256u
#define SLOW_BAUD 34u

typedef struct {
  char path[512];
  char profile[8];
  bool slow; /* forced to Baud Rate SLOW_BAUD */
  char name[600];
} replay_t;

/* True when a packet could change the Baud Rate: RESET, or a WRITE / REG_WRITE / SYNC_WRITE
 * whose window covers address 4. Leading extra 0xFF bytes are skipped. */
static bool packet_touches_baud(const uint8_t *p, size_t n) {
  size_t i = 0;
  while (i < n && p[i] == 0xFF) {
    i++;
  }
  if (i < 2 || i + 3 > n) {
    return false;
  }
  const uint8_t length = p[i + 1];
  const uint8_t instruction = p[i + 2];
  const size_t params = length >= 2 ? length - 2u : 0u;
  if (instruction == 0x06) {
    return true;
  }
  if ((instruction == 0x03 || instruction == 0x04) && params >= 2 && i + 3 < n) {
    const unsigned start = p[i + 3];
    return start <= 4 && start + (params - 1u) > 4;
  }
  if (instruction == 0x83 && params >= 2 && i + 4 < n) {
    const unsigned start = p[i + 3];
    return start <= 4 && start + p[i + 4] > 4;
  }
  return false;
}

static bool changes_baud(const conv_t *conv) {
  if (conv->baud != CONV_DEFAULT_BAUD) {
    return true;
  }
  for (size_t i = 0; i < conv->step_count; i++) {
    const conv_step_t *s = &conv->steps[i];
    if (s->kind == CONV_STEP_MASTER_BAUD ||
        (s->kind == CONV_STEP_EXCHANGE && packet_touches_baud(s->send, s->send_len))) {
      return true;
    }
  }
  return false;
}

static void replay(void **state) {
  const replay_t *r = *state;
  conv_t conv;
  char err[512];
  if (!conv_load(r->path, &conv, err, sizeof(err))) {
    fail_msg("%s", err);
  }
  if (!conv_applies_to_profile(&conv, r->profile) || (r->slow && changes_baud(&conv))) {
    conv_free(&conv);
    skip();
  }
  const unsigned baud = r->slow ? SLOW_BAUD : conv.baud;
  harness_t h;
  harness_open(&h, r->profile, "atmega88", baud);
  for (size_t i = 0; i < conv.servo_count; i++) {
    servo_t *s = harness_add_servo(&h, conv.servo_ids[i], (uint8_t)baud, NULL);
    board_set_temperature_c(&s->board, conv.temperature_c);
    /* A supply inside every voltage limit the conversations set (manual Example 12: 10..17 V),
     * so the control tick raises no input-voltage condition the manual's replies do not show. */
    board_set_supply_v(&s->board, 12.0);
  }
  harness_boot(&h, 5);
  for (size_t i = 0; i < conv.step_count; i++) {
    const conv_step_t *step = &conv.steps[i];
    switch (step->kind) {
    case CONV_STEP_MASTER_BAUD:
      master_set_baud_reg(h.master, step->master_baud);
      continue;
    case CONV_STEP_POWER_CYCLE:
      harness_power_cycle(&h);
      continue;
    case CONV_STEP_EXCHANGE:
    default:
      break;
    }
    uint8_t heard[HARNESS_MAX_REPLY];
    const size_t n = harness_exchange(&h, step->send, step->send_len, step->expect_len, heard, sizeof(heard));
    bool clean = true;
    for (size_t k = 0; k < master_rx_count(h.master); k++) {
      clean &= master_rx(h.master, k)->flags == 0;
    }
    if (n != step->expect_len || (n && memcmp(heard, step->expect, n) != 0) || !clean) {
      char sent[1024];
      char want[1024];
      char got[1024];
      snprintf(err, sizeof(err), "%s:%u (%s, Baud Rate %u): sent %s\n  expected %s\n  heard    %s%s", conv.path,
               step->expect_line ? step->expect_line : step->line, r->profile, baud,
               packet_hex(step->send, step->send_len, sent, sizeof(sent)),
               packet_hex(step->expect, step->expect_len, want, sizeof(want)), packet_hex(heard, n, got, sizeof(got)),
               clean ? "" : " (collided or garbled on the wire)");
      harness_close(&h);
      conv_free(&conv);
      fail_msg("%s", err);
    }
  }
  harness_close(&h);
  conv_free(&conv);
}

static int compare_paths(const void *a, const void *b) {
  return strcmp(((const replay_t *)a)->path, ((const replay_t *)b)->path);
}

int main(void) {
  static replay_t files[MAX_FILES];
  size_t count = 0;
  DIR *dir = opendir(AX12_CONVERSATIONS_DIR);
  if (!dir) {
    fprintf(stderr, "cannot open %s\n", AX12_CONVERSATIONS_DIR);
    return 1;
  }
  struct dirent *e;
  while ((e = readdir(dir)) != NULL && count < MAX_FILES) {
    const size_t n = strlen(e->d_name);
    if (n > 5 && strcmp(e->d_name + n - 5, ".conv") == 0) {
      snprintf(files[count].path, sizeof(files[count].path), "%s/%s", AX12_CONVERSATIONS_DIR, e->d_name);
      count++;
    }
  }
  closedir(dir);
  if (count == 0) {
    fprintf(stderr, "no .conv files in %s\n", AX12_CONVERSATIONS_DIR);
    return 1;
  }
  qsort(files, count, sizeof(files[0]), compare_paths);

  static replay_t runs[3u * MAX_FILES];
  static struct CMUnitTest tests[3u * MAX_FILES];
  static const struct {
    const char *profile;
    bool slow;
  } variants[] = {{"ax12", false}, {"ax12a", false}, {"ax12", true}};
  int failed = 0;
  for (size_t v = 0; v < sizeof(variants) / sizeof(variants[0]); v++) {
    for (size_t i = 0; i < count; i++) {
      replay_t *r = &runs[v * count + i];
      *r = files[i];
      snprintf(r->profile, sizeof(r->profile), "%s", variants[v].profile);
      r->slow = variants[v].slow;
      const char *slash = strrchr(r->path, '/');
      snprintf(r->name, sizeof(r->name), "%s", slash ? slash + 1 : r->path);
      tests[v * count + i] = (struct CMUnitTest){r->name, replay, NULL, NULL, r};
    }
    char group[64];
    snprintf(group, sizeof(group), "sim conversations (%s, %s)", variants[v].profile,
             variants[v].slow ? "Baud Rate 34" : "as written");
    failed += _cmocka_run_group_tests(group, &tests[v * count], count, NULL, NULL);
  }
  return failed;
}
