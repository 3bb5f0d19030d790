/* The packet finder (dxl_packet.h): framing, resynchronisation, the inter-byte gap and the
 * checksum, fed one byte at a time as the UART delivers them. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "bus_steps.h"
#include "dxl_packet.h"
#include "dxl_protocol.h"

#define MAX_FOUND 16u

typedef struct {
  dxl_find_result_t kind;
  uint8_t id;
  uint8_t instruction;
  uint8_t param_count;
  uint8_t params[256];
  uint8_t checksum;
} found_t;

typedef struct {
  dxl_finder_t finder;
  uint16_t now_ms;
  found_t found[MAX_FOUND];
  size_t count;
} finder_run_t;

static void given_finder(finder_run_t *run, uint16_t start_ms) {
  memset(run, 0, sizeof *run);
  dxl_finder_init(&run->finder);
  run->now_ms = start_ms;
}

/* Records every result the finder has until DXL_FIND_NONE. */
static void take_results(finder_run_t *run) {
  dxl_packet_t packet;
  dxl_find_result_t kind;
  while ((kind = dxl_finder_next(&run->finder, &packet)) != DXL_FIND_NONE) {
    assert_true(run->count < MAX_FOUND);
    found_t *f = &run->found[run->count++];
    f->kind = kind;
    f->id = packet.id;
    f->instruction = packet.instruction;
    f->param_count = packet.param_count;
    memcpy(f->params, packet.params, packet.param_count);
    f->checksum = packet.checksum;
  }
}

/* Pushes bytes at the current time and records every result. */
static void when_bytes_arrive(finder_run_t *run, const uint8_t *bytes, size_t count) {
  for (size_t i = 0; i < count; i++) {
    dxl_finder_push(&run->finder, bytes[i], run->now_ms);
    take_results(run);
  }
}

#define ARRIVE(run, ...) when_bytes_arrive((run), P(__VA_ARGS__))

/* The line idles until now_ms: poll, then take whatever the bytes before the gap still hold. */
static void when_line_idles_until(finder_run_t *run, uint16_t now_ms) {
  run->now_ms = now_ms;
  dxl_finder_poll(&run->finder, now_ms);
  take_results(run);
}

static void then_found_packet(const finder_run_t *run, size_t index, uint8_t id, uint8_t instruction,
                              uint8_t param_count) {
  assert_true(index < run->count);
  assert_int_equal(run->found[index].kind, DXL_FIND_PACKET);
  assert_int_equal(run->found[index].id, id);
  assert_int_equal(run->found[index].instruction, instruction);
  assert_int_equal(run->found[index].param_count, param_count);
}

static void test_a_ping_is_found_when_its_last_byte_arrives(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02, 0x01);
  assert_int_equal(run.count, 0);
  ARRIVE(&run, 0xFB);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 1, DXL_INST_PING, 0);
  assert_int_equal(run.found[0].checksum, 0xFB);
}

static void test_parameters_are_reported_in_order(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0x00, 0x07, 0x03, 0x1E, 0x00, 0x02, 0x00, 0x02, 0xD3); /* manual example 18 */
  then_found_packet(&run, 0, 0, DXL_INST_WRITE, 5);
  assert_memory_equal(run.found[0].params, ((const uint8_t[]){0x1E, 0x00, 0x02, 0x00, 0x02}), 5);
}

static void test_extra_leading_header_bytes_are_tolerated(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 1, DXL_INST_PING, 0);
}

static void test_the_broadcast_id_is_framed(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0xFE, 0x02, 0x05, 0xFA); /* manual example 19 ACTION */
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, DXL_ID_BROADCAST, DXL_INST_ACTION, 0);
}

static void test_the_finder_resyncs_after_garbage(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  ARRIVE(&run, 0x00, 0x12, 0xFF, 0x34, 0xFF, 0x00, 0xFE, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 1, DXL_INST_PING, 0);
}

static void test_a_packet_starting_inside_a_bad_candidate_is_still_found(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  /* FF FF 05 03 opens a candidate of 7 bytes that swallows the start of a PING; its checksum
   * is wrong, so the finder rescans from its second byte and finds the PING. */
  ARRIVE(&run, 0xFF, 0xFF, 0x05, 0x03, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB);
  assert_int_equal(run.count, 2);
  assert_int_equal(run.found[0].kind, DXL_FIND_BAD_CHECKSUM);
  assert_int_equal(run.found[0].id, 5);
  then_found_packet(&run, 1, 1, DXL_INST_PING, 0);
}

static void test_a_bad_checksum_is_reported_with_the_packet_fields(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x04, 0x03, 0x19, 0x01, 0x00);
  assert_int_equal(run.count, 1);
  assert_int_equal(run.found[0].kind, DXL_FIND_BAD_CHECKSUM);
  assert_int_equal(run.found[0].id, 1);
  assert_int_equal(run.found[0].instruction, DXL_INST_WRITE);
  assert_int_equal(run.found[0].param_count, 2);
  assert_int_equal(run.found[0].checksum, 0x00);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB);
  then_found_packet(&run, 1, 1, DXL_INST_PING, 0);
}

static void test_length_below_2_is_not_a_packet(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x01, 0xFD);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x00, 0xFE);
  assert_int_equal(run.count, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 1, DXL_INST_PING, 0);
}

static void test_a_gap_of_more_than_100ms_discards_a_partial_packet(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 1000);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02);
  run.now_ms = (uint16_t)(run.now_ms + DXL_PACKET_GAP_TIMEOUT_MS + 1u);
  ARRIVE(&run, 0x01, 0xFB);
  assert_int_equal(run.count, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB);
  assert_int_equal(run.count, 1);
}

static void test_a_gap_of_exactly_100ms_keeps_a_partial_packet(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 1000);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02);
  run.now_ms = (uint16_t)(run.now_ms + DXL_PACKET_GAP_TIMEOUT_MS);
  ARRIVE(&run, 0x01);
  run.now_ms = (uint16_t)(run.now_ms + DXL_PACKET_GAP_TIMEOUT_MS);
  ARRIVE(&run, 0xFB);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 1, DXL_INST_PING, 0);
}

static void test_the_gap_is_measured_across_the_wrap_of_the_ms_clock(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 65500u);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02, 0x01);
  run.now_ms = (uint16_t)(run.now_ms + DXL_PACKET_GAP_TIMEOUT_MS); /* 64 after the wrap */
  ARRIVE(&run, 0xFB);
  assert_int_equal(run.count, 1);

  given_finder(&run, 65500u);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02, 0x01);
  run.now_ms = (uint16_t)(run.now_ms + DXL_PACKET_GAP_TIMEOUT_MS + 1u);
  ARRIVE(&run, 0xFB);
  assert_int_equal(run.count, 0);
}

static void test_poll_discards_a_partial_packet_while_the_line_is_idle(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02, 0x01);
  when_line_idles_until(&run, DXL_PACKET_GAP_TIMEOUT_MS);
  assert_int_not_equal(run.finder.fill, 0); /* 100 ms: kept */
  when_line_idles_until(&run, DXL_PACKET_GAP_TIMEOUT_MS + 1u);
  assert_int_equal(run.finder.fill, 0);
  /* 200 ms later the poll would see only 100 ms if it never ran; it did, so nothing is left */
  run.now_ms = 2u * DXL_PACKET_GAP_TIMEOUT_MS;
  ARRIVE(&run, 0xFB);
  assert_int_equal(run.count, 0);
}

static void test_a_packet_hidden_behind_a_garbage_header_survives_a_gap(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  /* A garbage header announcing 200 bytes swallows a whole valid PING; then the line idles. */
  ARRIVE(&run, 0xFF, 0xFF, 0x07, 0xC8, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB);
  assert_int_equal(run.count, 0);
  when_line_idles_until(&run, DXL_PACKET_GAP_TIMEOUT_MS + 1u);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 0x01, 0x01, 0);
  assert_int_equal(run.finder.fill, 0);
  /* and what follows the gap is framed afresh */
  ARRIVE(&run, 0xFF, 0xFF, 0x02, 0x02, 0x01, 0xFA);
  assert_int_equal(run.count, 2);
  then_found_packet(&run, 1, 0x02, 0x01, 0);
}

static void test_no_packet_spans_a_gap(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02);
  run.now_ms = DXL_PACKET_GAP_TIMEOUT_MS + 1u;
  ARRIVE(&run, 0x01, 0xFB); /* would complete a PING, but came after the gap */
  assert_int_equal(run.count, 0);
}

static void test_status_packets_of_other_servos_are_framed(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  /* A status packet: the error byte sits where the instruction would be. */
  ARRIVE(&run, 0xFF, 0xFF, 0x02, 0x03, 0x00, 0x20, 0xDA);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 2, 0x00, 1);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB);
  then_found_packet(&run, 1, 1, DXL_INST_PING, 0);
}

static void test_back_to_back_packets_are_each_found(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB, 0xFF, 0xFF, 0x02, 0x02, 0x01, 0xFA, 0xFF, 0xFF, 0xFE, 0x02, 0x05,
         0xFA);
  assert_int_equal(run.count, 3);
  then_found_packet(&run, 0, 1, DXL_INST_PING, 0);
  then_found_packet(&run, 1, 2, DXL_INST_PING, 0);
  then_found_packet(&run, 2, DXL_ID_BROADCAST, DXL_INST_ACTION, 0);
}

static void test_the_longest_packet_length_255_is_found(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  uint8_t params[253];
  for (size_t i = 0; i < sizeof params; i++) {
    params[i] = (uint8_t)i;
  }
  uint8_t packet[STEPS_PACKET_MAX];
  const size_t length = build_packet(packet, 1, DXL_INST_WRITE, params, sizeof params);
  assert_int_equal(length, DXL_PACKET_MAX_BYTES);
  when_bytes_arrive(&run, packet, length);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 1, DXL_INST_WRITE, 253);
  assert_memory_equal(run.found[0].params, params, sizeof params);
}

static void test_awaiting_checksum_describes_the_packet_before_its_last_byte(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  dxl_packet_t packet;
  uint8_t expected = 0;
  const uint8_t read[] = {0xFF, 0xFF, 0x01, 0x04, 0x02, 0x2B, 0x01, 0xCC}; /* manual example 2 */
  for (size_t i = 0; i + 1 < sizeof read; i++) {
    assert_false(dxl_finder_awaiting_checksum(&run.finder, &packet, &expected));
    when_bytes_arrive(&run, &read[i], 1);
  }
  assert_true(dxl_finder_awaiting_checksum(&run.finder, &packet, &expected));
  assert_int_equal(expected, 0xCC);
  assert_int_equal(packet.id, 1);
  assert_int_equal(packet.instruction, DXL_INST_READ);
  assert_int_equal(packet.param_count, 2);
  assert_int_equal(packet.params[0], 0x2B);
  assert_int_equal(packet.params[1], 0x01);
  when_bytes_arrive(&run, &read[sizeof read - 1], 1);
  assert_int_equal(run.count, 1);
  assert_false(dxl_finder_awaiting_checksum(&run.finder, &packet, &expected));
}

static void test_awaiting_checksum_is_false_while_garbage_is_pending(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  dxl_packet_t packet;
  uint8_t expected;
  /* the bytes are pushed but not yet examined: no claim is made */
  dxl_finder_push(&run.finder, 0xFF, 0);
  dxl_finder_push(&run.finder, 0xFF, 0);
  dxl_finder_push(&run.finder, 0x01, 0);
  dxl_finder_push(&run.finder, 0x02, 0);
  dxl_finder_push(&run.finder, 0x01, 0);
  assert_false(dxl_finder_awaiting_checksum(&run.finder, &packet, &expected));
  assert_int_equal(dxl_finder_next(&run.finder, &packet), DXL_FIND_NONE);
  assert_true(dxl_finder_awaiting_checksum(&run.finder, &packet, &expected));
  assert_int_equal(expected, 0xFB);
}

static void test_checksum_matches_the_manual_examples(void **state) {
  (void)state;
  assert_int_equal(dxl_checksum((const uint8_t[]){0xFE, 0x04, 0x03, 0x03, 0x01}, 5), 0xF6);
  assert_int_equal(dxl_checksum((const uint8_t[]){0x01, 0x03, 0x00, 0x20}, 4), 0xDB);
  const uint8_t ex5[] = {0xFE, 0x18, 0x83, 0x1E, 0x04, 0x00, 0x10, 0x00, 0x50, 0x01, 0x01, 0x20, 0x02, 0x60,
                         0x03, 0x02, 0x30, 0x00, 0x70, 0x01, 0x03, 0x20, 0x02, 0x80, 0x03};
  assert_int_equal(dxl_checksum(ex5, sizeof ex5), 0x12);
  assert_int_equal(dxl_checksum(NULL, 0), 0xFF);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_a_ping_is_found_when_its_last_byte_arrives),
      cmocka_unit_test(test_parameters_are_reported_in_order),
      cmocka_unit_test(test_extra_leading_header_bytes_are_tolerated),
      cmocka_unit_test(test_the_broadcast_id_is_framed),
      cmocka_unit_test(test_the_finder_resyncs_after_garbage),
      cmocka_unit_test(test_a_packet_starting_inside_a_bad_candidate_is_still_found),
      cmocka_unit_test(test_a_bad_checksum_is_reported_with_the_packet_fields),
      cmocka_unit_test(test_length_below_2_is_not_a_packet),
      cmocka_unit_test(test_a_gap_of_more_than_100ms_discards_a_partial_packet),
      cmocka_unit_test(test_a_gap_of_exactly_100ms_keeps_a_partial_packet),
      cmocka_unit_test(test_the_gap_is_measured_across_the_wrap_of_the_ms_clock),
      cmocka_unit_test(test_poll_discards_a_partial_packet_while_the_line_is_idle),
      cmocka_unit_test(test_a_packet_hidden_behind_a_garbage_header_survives_a_gap),
      cmocka_unit_test(test_no_packet_spans_a_gap),
      cmocka_unit_test(test_status_packets_of_other_servos_are_framed),
      cmocka_unit_test(test_back_to_back_packets_are_each_found),
      cmocka_unit_test(test_the_longest_packet_length_255_is_found),
      cmocka_unit_test(test_awaiting_checksum_describes_the_packet_before_its_last_byte),
      cmocka_unit_test(test_awaiting_checksum_is_false_while_garbage_is_pending),
      cmocka_unit_test(test_checksum_matches_the_manual_examples),
  };
  return cmocka_run_group_tests_name("packet finder (" AX12_PROFILE_NAME ")", tests, NULL, NULL);
}
