/* The conversation suite (test/conversations/, every .conv file) replayed against the host build of the
 * core, one cmocka test per file; files for the other profile are skipped. Also the reader's
 * own tests: what it accepts and how it reports errors. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "bus_steps.h"
#include "conformance_log.h"
#include "conversation.h"

#define MAX_FILES 256u
#define PATH_CHARS 512u

/* --- the reader ----------------------------------------------------------------------- */

static void parse_ok(const char *text, conv_t *conv) {
  char err[256];
  if (!conv_parse("t.conv", text, conv, err, sizeof err)) {
    fail_msg("unexpected parse error: %s", err);
  }
}

static void parse_fails_with(const char *text, const char *expected_message) {
  conv_t conv;
  char err[256];
  assert_false(conv_parse("t.conv", text, &conv, err, sizeof err));
  if (strstr(err, expected_message) == NULL) {
    fail_msg("error '%s' does not contain '%s'", err, expected_message);
  }
  assert_int_equal(conv.step_count, 0);
  conv_free(&conv);
}

static void test_reader_defaults_are_one_servo_id_1_at_1mbps_25_degrees(void **state) {
  (void)state;
  conv_t conv;
  parse_ok("> FF FF 01 02 01 FB\n< FF FF 01 02 00 FC\n", &conv);
  assert_string_equal(conv.profile, "");
  assert_int_equal(conv.servo_count, 1);
  assert_int_equal(conv.servo_ids[0], 1);
  assert_int_equal(conv.baud, 1);
  assert_int_equal(conv.temperature_c, 25);
  assert_true(conv_applies_to_profile(&conv, "ax12"));
  assert_true(conv_applies_to_profile(&conv, "ax12a"));
  assert_int_equal(conv.step_count, 1);
  assert_int_equal(conv.steps[0].kind, CONV_STEP_EXCHANGE);
  assert_int_equal(conv.steps[0].send_len, 6);
  assert_memory_equal(conv.steps[0].send, ((const uint8_t[]){0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB}), 6);
  assert_int_equal(conv.steps[0].expect_len, 6);
  assert_int_equal(conv.steps[0].line, 1);
  assert_int_equal(conv.steps[0].expect_line, 2);
  conv_free(&conv);
}

static void test_reader_reads_every_directive(void **state) {
  (void)state;
  conv_t conv;
  parse_ok("# comment\n"
           "profile ax12a   # trailing comment\n"
           "servos 0, 1,2\n"
           "baud 34\n"
           "temperature 32\n"
           "\n"
           ">  0xFF ff FE 02 05 FA\n"
           "< none\n"
           "master-baud 1\n"
           "power-cycle\r\n"
           "> FF FF 00 02 01 FC\n"
           "< FF FF 00 02 00 FD\n"
           "< FF FF 01 02 00 FC\n",
           &conv);
  assert_string_equal(conv.profile, "ax12a");
  assert_false(conv_applies_to_profile(&conv, "ax12"));
  assert_true(conv_applies_to_profile(&conv, "ax12a"));
  assert_int_equal(conv.servo_count, 3);
  assert_int_equal(conv.servo_ids[2], 2);
  assert_int_equal(conv.baud, 34);
  assert_int_equal(conv.temperature_c, 32);
  assert_int_equal(conv.step_count, 4);
  assert_int_equal(conv.steps[0].expect_len, 0);
  assert_int_equal(conv.steps[0].send[0], 0xFF);
  assert_int_equal(conv.steps[0].send[2], 0xFE);
  assert_int_equal(conv.steps[1].kind, CONV_STEP_MASTER_BAUD);
  assert_int_equal(conv.steps[1].master_baud, 1);
  assert_int_equal(conv.steps[2].kind, CONV_STEP_POWER_CYCLE);
  assert_int_equal(conv.steps[3].expect_len, 12); /* two `<` lines are concatenated */
  assert_int_equal(conv.steps[3].line, 11);
  conv_free(&conv);
}

static void test_reader_reports_file_and_line_of_errors(void **state) {
  (void)state;
  parse_fails_with("> FF FF 01 02 01 FB\n< FF FF 01 02 00 FC\n> FF GG\n< none\n", "t.conv:3: 'GG' is not");
  parse_fails_with("> FF FF 01 02 01 FB\n", "t.conv:1: '>' has no '<'");
  parse_fails_with("> FF FF 01 02 01 FB\n> FF FF 01 02 01 FB\n< none\n", "t.conv:1: '>' has no '<'");
  parse_fails_with("< none\n", "t.conv:1: '<' without a '>'");
  parse_fails_with("> FF\n< none\n< FF\n", "t.conv:3: '< none' must be the only");
  parse_fails_with("> FF\n< FF\n< none\n", "t.conv:3: '< none' must be the only");
  parse_fails_with("servos 1\nprofile ax12\n> FF\n< none\n", "t.conv:2: 'profile' must be the first");
  parse_fails_with("profile ax18\n> FF\n< none\n", "t.conv:1: profile: 'ax18'");
  parse_fails_with("> FF\n< none\nservos 1\n", "t.conv:3: 'servos' must come before");
  parse_fails_with("baud 1\nbaud 2\n> FF\n< none\n", "t.conv:2: 'baud' given twice");
  parse_fails_with("servos 1,1\n> FF\n< none\n", "t.conv:1: servos: ID 1 listed twice");
  parse_fails_with("servos 254\n> FF\n< none\n", "t.conv:1: servos: 254 is out of range");
  parse_fails_with("baud 255\n> FF\n< none\n", "t.conv:1: baud: 255 is out of range");
  parse_fails_with("temperature -1\n> FF\n< none\n", "t.conv:1: temperature: '-1' is not");
  parse_fails_with("> FF\n< none\nmaster-baud\n", "t.conv:3: master-baud: a number is missing");
  parse_fails_with("> FF\n< none\npower-cycle now\n", "t.conv:3: power-cycle takes no argument");
  parse_fails_with("> FF\n< none\nwait 100\n", "t.conv:3: unknown directive 'wait'");
  parse_fails_with(">\n< none\n", "t.conv:1: no bytes given");
  parse_fails_with("> 1FF\n< none\n", "t.conv:1: '1FF' is not");
  parse_fails_with("# only a comment\n", "no '>' exchange");
}

static void test_reader_reports_a_missing_file(void **state) {
  (void)state;
  conv_t conv;
  char err[256];
  assert_false(conv_load("/nonexistent/x.conv", &conv, err, sizeof err));
  assert_non_null(strstr(err, "/nonexistent/x.conv:0: cannot open"));
  conv_free(&conv);
}

/* --- the suite ------------------------------------------------------------------------ */

/* The comments of a conversation file, for the conformance log: the first block of full-line
 * comments (after a `profile` line, if any) describes the file; every other comment becomes a
 * note of a step: a full-line comment of the step after it, a trailing one of the step whose
 * lines it is on. notes[i] belongs to conv->steps[i]. Only called when the log is on. */
#define CONV_TEXT_MAX 8192u

typedef struct {
  char description[CONV_TEXT_MAX];
  char *notes; /* step_count x CONV_TEXT_MAX */
} conv_comments_t;

static void append_text(char *to, const char *text, size_t text_len) {
  const size_t used = strlen(to);
  snprintf(to + used, CONV_TEXT_MAX - used, "%s%.*s", used == 0 ? "" : " ", (int)text_len, text);
}

static size_t step_of_line(const conv_t *conv, unsigned line, bool full_line) {
  if (full_line) { /* the first step after it */
    for (size_t i = 0; i < conv->step_count; i++) {
      if (conv->steps[i].line > line) {
        return i;
      }
    }
    return conv->step_count;
  }
  size_t found = conv->step_count; /* the last step starting at or before it */
  for (size_t i = 0; i < conv->step_count && conv->steps[i].line <= line; i++) {
    found = i;
  }
  return found;
}

static void read_conv_comments(const conv_t *conv, conv_comments_t *out) {
  out->description[0] = '\0';
  out->notes = calloc(conv->step_count + 1u, CONV_TEXT_MAX);
  FILE *f = fopen(conv->path, "r");
  if (f == NULL || out->notes == NULL) {
    if (f != NULL) {
      fclose(f);
    }
    return;
  }
  char line[1024];
  unsigned number = 0;
  bool in_description = true;
  while (fgets(line, sizeof line, f) != NULL) {
    number++;
    line[strcspn(line, "\r\n")] = '\0';
    const char *text = line + strspn(line, " \t");
    const char *hash = strchr(text, '#');
    if (hash == NULL) {
      if (text[0] != '\0' && strncmp(text, "profile", 7) != 0) {
        in_description = false;
      }
      continue;
    }
    const bool full_line = hash == text;
    const char *comment = hash + 1 + strspn(hash + 1, " \t");
    if (full_line && in_description) {
      append_text(out->description, comment, strlen(comment));
      continue;
    }
    in_description = false;
    const size_t step = step_of_line(conv, number, full_line);
    if (step < conv->step_count) {
      append_text(out->notes + step * CONV_TEXT_MAX, comment, strlen(comment));
    }
  }
  fclose(f);
}

static int conversation_teardown(void **state) {
  (void)state;
  conformance_end();
  return 0;
}

static void replay_conversation_file(void **state) {
  const char *path = *state;
  conv_t conv;
  char err[512];
  if (!conv_load(path, &conv, err, sizeof err)) {
    fail_msg("%s", err);
  }
  if (!conv_applies_to_profile(&conv, AX12_PROFILE_NAME)) {
    conv_free(&conv);
    skip();
  }
  static conv_comments_t comments;
  comments.notes = NULL;
  if (conformance_enabled()) {
    const char *slash = strrchr(path, '/');
    read_conv_comments(&conv, &comments);
    conformance_begin("conversations", slash != NULL ? slash + 1 : path, CONFORMANCE_CONVERSATION, NULL, NULL);
    conformance_field_str("description", comments.description);
    conformance_field_str("applies_to", conv.profile[0] != '\0' ? conv.profile : "both");
  }
  static host_bus_t bus;
  conv_bus_init(&bus, &conv);
  char msg[4096];
  for (size_t i = 0; i < conv.step_count; i++) {
    if (comments.notes != NULL && comments.notes[i * CONV_TEXT_MAX] != '\0') {
      conformance_note(&comments.notes[i * CONV_TEXT_MAX]);
    }
    if (!conv_replay_step(&bus, &conv, &conv.steps[i], msg, sizeof msg)) {
      conv_free(&conv);
      free(comments.notes);
      fail_msg("%s", msg);
    }
  }
  conv_free(&conv);
  free(comments.notes);
}

int main(void) {
  static const struct CMUnitTest reader_tests[] = {
      cmocka_unit_test(test_reader_defaults_are_one_servo_id_1_at_1mbps_25_degrees),
      cmocka_unit_test(test_reader_reads_every_directive),
      cmocka_unit_test(test_reader_reports_file_and_line_of_errors),
      cmocka_unit_test(test_reader_reports_a_missing_file),
  };
  int failed = cmocka_run_group_tests_name("conversation reader", reader_tests, NULL, NULL);

  static char *paths[MAX_FILES];
  static struct CMUnitTest suite[MAX_FILES];
  const size_t count = conv_list_files(AX12_CONVERSATIONS_DIR, paths, MAX_FILES, PATH_CHARS);
  if (count == 0) {
    fprintf(stderr, "no .conv files in %s\n", AX12_CONVERSATIONS_DIR);
    return 1;
  }
  for (size_t i = 0; i < count; i++) {
    const char *slash = strrchr(paths[i], '/');
    suite[i] = (struct CMUnitTest){slash != NULL ? slash + 1 : paths[i], replay_conversation_file, NULL,
                                   conversation_teardown, paths[i]};
  }
  failed += _cmocka_run_group_tests("conversations (" AX12_PROFILE_NAME ")", suite, count, NULL, NULL);
  for (size_t i = 0; i < count; i++) {
    free(paths[i]);
  }
  return failed;
}
