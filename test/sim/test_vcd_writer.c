/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The VCD writer (model/host/vcd_writer.c) on its own: the header and declarations, only
 * changes written, a time stamp once per time, exact cycles in 100 ps units, identifiers past
 * 94 variables, and a file that ends on a whole line at every flush, buffer-full ones included. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "vcd_writer.h"

static char *read_all(const char *path) {
  FILE *f = fopen(path, "rb");
  assert_non_null(f);
  fseek(f, 0, SEEK_END);
  const long size = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *text = calloc(1, (size_t)size + 1u);
  assert_non_null(text);
  assert_int_equal(fread(text, 1, (size_t)size, f), (size_t)size);
  fclose(f);
  return text;
}

static void temp_path(char *path, size_t len) {
  snprintf(path, len, "/tmp/ax12-vcd-writer-XXXXXX");
  const int fd = mkstemp(path);
  assert_true(fd >= 0);
  close(fd);
}

/* The body after $enddefinitions. */
static const char *body(const char *text) {
  const char *b = strstr(text, "$enddefinitions $end\n");
  assert_non_null(b);
  return b + strlen("$enddefinitions $end\n");
}

static void test_declarations_then_only_changes_with_one_stamp_per_time(void **state) {
  (void)state;
  char path[64], err[160];
  temp_path(path, sizeof(path));
  vcd_writer_t w;
  assert_int_equal(vcd_writer_open(&w, path, "test", err, sizeof(err)), 0);
  vcd_writer_scope(&w, "servo_1");
  const int rx = vcd_writer_var(&w, "rx", 1);
  const int duty = vcd_writer_var(&w, "duty", 8);
  vcd_writer_scope_end(&w);
  assert_int_equal(rx, 0);
  assert_int_equal(duty, 1);
  assert_int_equal(vcd_writer_var(&w, "wide", 33), -1);
  vcd_writer_initial(&w, rx, 1);
  vcd_writer_begin(&w, 0);
  vcd_writer_change(&w, 16, rx, 1);    /* no change: dropped */
  vcd_writer_change(&w, 16, rx, 0);
  vcd_writer_change(&w, 16, duty, 5);  /* same time: no second stamp */
  vcd_writer_change(&w, 32, duty, 0x1FF); /* masked to 8 bits */
  vcd_writer_change(&w, 32, duty, 0xFF); /* the same value again: dropped */
  assert_int_equal(vcd_writer_close(&w, 100), 0);
  char *text = read_all(path);
  assert_non_null(strstr(text, "$timescale 100 ps $end\n"));
  assert_non_null(strstr(text, "$scope module servo_1 $end\n$var wire 1 ! rx $end\n$var wire 8 \" duty $end\n"
                               "$upscope $end\n"));
  assert_string_equal(body(text), "#0\n$dumpvars\n1!\nb0 \"\n$end\n"
                                  "#10000\n0!\nb101 \"\n"
                                  "#20000\nb11111111 \"\n"
                                  "#62500\n");
  free(text);
  unlink(path);
}

static void test_identifiers_past_94_variables_take_two_characters(void **state) {
  (void)state;
  char path[64], err[160];
  temp_path(path, sizeof(path));
  vcd_writer_t w;
  assert_int_equal(vcd_writer_open(&w, path, "test", err, sizeof(err)), 0);
  char name[16];
  int last = -1;
  for (int i = 0; i < 96; i++) {
    snprintf(name, sizeof(name), "v%d", i);
    last = vcd_writer_var(&w, name, 1);
  }
  assert_int_equal(last, 95);
  vcd_writer_begin(&w, 0);
  assert_int_equal(vcd_writer_close(&w, 0), 0);
  char *text = read_all(path);
  assert_non_null(strstr(text, "$var wire 1 ~ v93 $end\n$var wire 1 !\" v94 $end\n$var wire 1 \"\" v95 $end\n"));
  free(text);
  unlink(path);
}

static void test_a_full_buffer_goes_out_on_a_line_boundary(void **state) {
  (void)state;
  char path[64], err[160];
  temp_path(path, sizeof(path));
  vcd_writer_t w;
  assert_int_equal(vcd_writer_open(&w, path, "test", err, sizeof(err)), 0);
  const int v = vcd_writer_var(&w, "v", 1);
  vcd_writer_begin(&w, 0);
  for (sim_cycles_t t = 1; w.bytes_written == 0; t++) {
    vcd_writer_change(&w, t, v, (uint32_t)(t & 1u));
  }
  /* What is on disk now (no close yet): whole lines, each a stamp or a change. */
  char *text = read_all(path);
  const size_t len = strlen(text);
  assert_true(len > VCD_WRITER_BUFFER / 2);
  assert_int_equal(text[len - 1], '\n');
  free(text);
  assert_int_equal(vcd_writer_close(&w, 0), 0);
  unlink(path);
}

static void test_an_uncreatable_file_is_reported(void **state) {
  (void)state;
  char err[160] = "";
  vcd_writer_t w;
  assert_int_equal(vcd_writer_open(&w, "/nonexistent-dir/x.vcd", "test", err, sizeof(err)), -1);
  assert_non_null(strstr(err, "/nonexistent-dir/x.vcd"));
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_declarations_then_only_changes_with_one_stamp_per_time),
      cmocka_unit_test(test_identifiers_past_94_variables_take_two_characters),
      cmocka_unit_test(test_a_full_buffer_goes_out_on_a_line_boundary),
      cmocka_unit_test(test_an_uncreatable_file_is_reported),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
