/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The bus log (model/host/bus_log.c) on its own: the header row, one row per record, rows in
 * the file (not only in stdio's buffer) once the flush period has passed, everything at close,
 * and a write that fails (/dev/full) reported, not ignored. */
#define _GNU_SOURCE
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "bus_log.h"

static const uint8_t ping[] = {0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};

static bus_packet_t ping_record(sim_cycles_t start) {
  return (bus_packet_t){.kind = BUS_PACKET_INSTRUCTION,
                        .start = start,
                        .end = start + 960,
                        .sender_name = "client",
                        .id = 1,
                        .length = 2,
                        .code = 0x01,
                        .checksum = 0xFB,
                        .checksum_ok = true,
                        .raw = ping,
                        .raw_count = sizeof(ping)};
}

/* What another reader of the file sees now (what a kill would leave). */
static size_t file_bytes(const char *path, char *text, size_t len) {
  FILE *f = fopen(path, "r");
  assert_non_null(f);
  const size_t n = fread(text, 1, len - 1, f);
  text[n] = '\0';
  fclose(f);
  return n;
}

static void test_rows_reach_the_file_at_the_flush_period_and_at_close(void **state) {
  (void)state;
  char path[] = "/tmp/ax12-bus-log-test-XXXXXX";
  const int fd = mkstemp(path);
  assert_true(fd >= 0);
  close(fd);
  bus_log_t log;
  char err[256];
  assert_int_equal(bus_log_open(&log, path, err, sizeof(err)), 0);
  char text[4096];
  file_bytes(path, text, sizeof(text));
  assert_string_equal(text, BUS_PACKET_CSV_HEADER); /* the header at once */

  const char *row1 = "1.0000,61.0000,client,instruction,1,0x01,PING,,1,0,,FF FF 01 02 01 FB\n";
  const char *row2 = "2.0000,62.0000,client,instruction,1,0x01,PING,,1,0,,FF FF 01 02 01 FB\n";
  const char *row3 = "3.0000,63.0000,client,instruction,1,0x01,PING,,1,0,,FF FF 01 02 01 FB\n";
  char want[4096];
  const bus_packet_t p1 = ping_record(16), p2 = ping_record(32), p3 = ping_record(48);
  bus_log_tick(&log, 500.0); /* nothing waiting: nothing to do */
  bus_log_packet(&log, &p1);
  bus_log_tick(&log, 1000.0); /* the first rows: written at once */
  snprintf(want, sizeof(want), "%s%s", BUS_PACKET_CSV_HEADER, row1);
  file_bytes(path, text, sizeof(text));
  assert_string_equal(text, want);
  bus_log_packet(&log, &p2);
  bus_log_tick(&log, 1000.0 + BUS_LOG_FLUSH_US - 1.0);
  file_bytes(path, text, sizeof(text));
  assert_string_equal(text, want); /* within the period: still buffered */
  bus_log_tick(&log, 1000.0 + BUS_LOG_FLUSH_US);
  snprintf(want, sizeof(want), "%s%s%s", BUS_PACKET_CSV_HEADER, row1, row2);
  file_bytes(path, text, sizeof(text));
  assert_string_equal(text, want);
  bus_log_packet(&log, &p3);
  assert_int_equal(bus_log_close(&log, err, sizeof(err)), 0);
  snprintf(want, sizeof(want), "%s%s%s%s", BUS_PACKET_CSV_HEADER, row1, row2, row3);
  file_bytes(path, text, sizeof(text));
  assert_string_equal(text, want); /* the rest at close */
  assert_int_equal(log.rows, 3);
  unlink(path);
}

static void test_a_file_that_cannot_be_written_is_reported(void **state) {
  (void)state;
  bus_log_t log;
  char err[4200];
  assert_int_equal(bus_log_open(&log, "/nonexistent-dir/x.csv", err, sizeof(err)), -1);
  assert_non_null(strstr(err, "--log-bus /nonexistent-dir/x.csv: "));
  if (access("/dev/full", W_OK) != 0) {
    skip();
  }
  /* /dev/full takes nothing: the header's flush fails at open. */
  assert_int_equal(bus_log_open(&log, "/dev/full", err, sizeof(err)), -1);
  assert_non_null(strstr(err, "--log-bus /dev/full: "));
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_rows_reach_the_file_at_the_flush_period_and_at_close),
      cmocka_unit_test(test_a_file_that_cannot_be_written_is_reported),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
