/* The packet finder (dxl_packet.h) and the framing step under it (dxl_frame.h): framing by
 * LENGTH, what follows a packet for another ID, a bad checksum or a gap, and the checksum, fed
 * one byte at a time as the UART delivers them and in batches as the link layer pushes them. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
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
  uint16_t last_byte_ms;
  found_t found[MAX_FOUND];
  size_t count;
} finder_run_t;

static void given_finder(finder_run_t *run, uint16_t start_ms) {
  memset(run, 0, sizeof *run);
  dxl_finder_init(&run->finder);
  run->now_ms = start_ms;
  run->last_byte_ms = start_ms;
}

static void record(finder_run_t *run, dxl_find_result_t kind, const dxl_packet_t *packet) {
  if (kind == DXL_FIND_NONE) {
    return;
  }
  assert_true(run->count < MAX_FOUND);
  found_t *f = &run->found[run->count++];
  f->kind = kind;
  f->id = packet->id;
  f->instruction = packet->instruction;
  f->param_count = packet->param_count;
  memcpy(f->params, packet->params, packet->param_count);
  f->checksum = packet->checksum;
}

/* Pushes bytes at the current time, as a reader with a millisecond clock does: a byte more than
 * 100 ms after the one before it comes after a gap (dxl_frame_gap). Records every result. */
static void when_bytes_arrive(finder_run_t *run, const uint8_t *bytes, size_t count) {
  for (size_t i = 0; i < count; i++) {
    if (dxl_frame_gap(run->last_byte_ms, run->now_ms)) {
      dxl_finder_gap(&run->finder);
    }
    run->last_byte_ms = run->now_ms;
    dxl_packet_t packet;
    record(run, dxl_finder_push(&run->finder, bytes[i], &packet), &packet);
  }
}

#define ARRIVE(run, ...) when_bytes_arrive((run), P(__VA_ARGS__))

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

/* docs/policy.md "Framing and bus": a packet is the LENGTH bytes after its header, whatever its
 * checksum turns out to be, and the search goes on after them. */
static void test_a_bad_packet_takes_the_bytes_its_length_counts(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  /* FF FF 05 03 counts three bytes, FF FF 01, which begin a PING: its checksum is wrong, and
   * what is left of the PING is garbage. */
  ARRIVE(&run, 0xFF, 0xFF, 0x05, 0x03, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB);
  assert_int_equal(run.count, 1);
  assert_int_equal(run.found[0].kind, DXL_FIND_BAD_CHECKSUM);
  assert_int_equal(run.found[0].id, 5);
  assert_int_equal(run.found[0].checksum, 0x01);
  /* and the next packet is found from its first byte */
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB);
  assert_int_equal(run.count, 2);
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

/* A gap ends the packet under way, its bytes included: the finder is idle at once, the next
 * byte starts a search. */
static void test_a_gap_leaves_the_finder_idle(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0x01, 0x02, 0x01);
  assert_false(dxl_finder_idle(&run.finder));
  assert_int_equal(dxl_finder_left(&run.finder), 1);
  dxl_finder_gap(&run.finder);
  assert_true(dxl_finder_idle(&run.finder));
  assert_int_equal(dxl_finder_left(&run.finder), 0);
  ARRIVE(&run, 0xFB);
  assert_int_equal(run.count, 0);
}

/* A garbage header whose LENGTH covers a whole PING: the PING is part of it, not a packet, and
 * is not found when the line then idles past the gap (nothing is rescanned); what follows the
 * gap is framed afresh. */
static void test_a_packet_inside_a_garbage_headers_length_is_not_a_packet(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0x07, 0xC8, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB);
  assert_int_equal(run.count, 0);
  run.now_ms = DXL_PACKET_GAP_TIMEOUT_MS + 1u;
  ARRIVE(&run, 0xFF, 0xFF, 0x02, 0x02, 0x01, 0xFA);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 0x02, 0x01, 0);
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

/* A batch of no bytes (the link layer's take when the ring is empty) is no byte, in a header
 * and in a body. */
static void test_an_empty_batch_is_no_byte(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  dxl_packet_t packet;
  uint16_t count;
  ARRIVE(&run, 0xFF, 0xFF, 0x01);
  (void)dxl_finder_slot(&run.finder, &count);
  assert_int_equal(count, 1);
  assert_int_equal(dxl_finder_pushed(&run.finder, 0, &packet), DXL_FIND_NONE);
  ARRIVE(&run, 0x02, 0x01);
  (void)dxl_finder_slot(&run.finder, &count);
  assert_int_equal(count, 1); /* the checksum: a batch never passes a packet's end */
  assert_int_equal(dxl_finder_pushed(&run.finder, 0, &packet), DXL_FIND_NONE);
  ARRIVE(&run, 0xFB);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 1, DXL_INST_PING, 0);
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
  const size_t length = packet_encode(packet, 1, DXL_INST_WRITE, params, sizeof params);
  assert_int_equal(length, DXL_PACKET_MAX_BYTES);
  when_bytes_arrive(&run, packet, length);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 1, DXL_INST_WRITE, 253);
  assert_memory_equal(run.found[0].params, params, sizeof params);
}

/* The firmware prepares a streamed reply from the candidate once every byte but the
 * checksum is in and examined: leading extra 0xFF bytes are gone by then. */
static void test_the_candidate_describes_the_packet_before_its_checksum(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  dxl_packet_t packet;
  /* manual example 2 with a third header byte, without its checksum 0xCC */
  ARRIVE(&run, 0xFF, 0xFF, 0xFF, 0x01, 0x04, 0x02, 0x2B, 0x01);
  assert_int_equal(run.count, 0);
  dxl_finder_candidate(&run.finder, &packet);
  assert_int_equal(packet.id, 1);
  assert_int_equal(packet.instruction, DXL_INST_READ);
  assert_int_equal(packet.param_count, 2);
  assert_int_equal(packet.params[0], 0x2B);
  assert_int_equal(packet.params[1], 0x01);
  ARRIVE(&run, 0xCC);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 1, DXL_INST_READ, 2);
}

/* The link layer pushes what the ring holds in batches (dxl_finder_slot: a packet's body in one
 * tight loop); a host pushes byte by byte. A seeded stream of packets (some with a bad
 * checksum), garbage rich in 0xFF and gaps, cut into batches of 1..40 bytes, gives the same
 * results in the same order. */
static uint32_t next_random(uint32_t *state) {
  *state = *state * 1664525u + 1013904223u;
  return *state >> 8;
}

typedef struct {
  dxl_finder_t finder;
  uint32_t digest[2048]; /* one per result: kind, id, instruction, count, params */
  size_t count;
} digest_run_t;

static void digest_result(digest_run_t *run, dxl_find_result_t kind, const dxl_packet_t *p) {
  if (kind != DXL_FIND_NONE) {
    const dxl_packet_t packet = *p;
    uint32_t d = (uint32_t)kind * 16777619u ^ packet.id;
    d = d * 16777619u ^ packet.instruction;
    d = d * 16777619u ^ packet.param_count;
    for (unsigned i = 0; i < packet.param_count; i++) {
      d = d * 16777619u ^ packet.params[i];
    }
    assert_true(run->count < sizeof run->digest / sizeof run->digest[0]);
    run->digest[run->count++] = d;
  }
}

static size_t random_stream(uint8_t *out, size_t capacity, bool *gap_before, uint32_t *seed) {
  size_t n = 0;
  while (n + 16 < capacity) {
    gap_before[n] = next_random(seed) % 16u == 0;
    if (next_random(seed) % 4u == 0) { /* garbage */
      out[n++] = (next_random(seed) & 1u) ? 0xFF : (uint8_t)next_random(seed);
      continue;
    }
    const uint8_t params[3] = {(uint8_t)next_random(seed), (uint8_t)next_random(seed), 0xFF};
    uint8_t packet[16];
    const size_t length = packet_encode(packet, (uint8_t)(next_random(seed) % 4u), (uint8_t)(1u + next_random(seed) % 6u),
                                       params, next_random(seed) % 4u);
    if (next_random(seed) % 8u == 0) {
      packet[length - 1] ^= 0x01; /* a bad checksum */
    }
    memcpy(&out[n], packet, length);
    n += length;
  }
  return n;
}

static void test_batches_find_what_single_bytes_find(void **state) {
  (void)state;
  enum { STREAM = 6000 };
  static uint8_t stream[STREAM];
  static bool gap_before[STREAM];
  static digest_run_t single, batched;
  uint32_t seed = 20261121u;
  const size_t n = random_stream(stream, STREAM, gap_before, &seed);
  dxl_finder_init(&single.finder);
  dxl_finder_init(&batched.finder);
  for (size_t i = 0; i < n;) {
    size_t batch = 1u + next_random(&seed) % 40u;
    if (batch > n - i) {
      batch = n - i;
    }
    for (size_t k = 1; k < batch; k++) { /* a gap only ever comes before a batch */
      if (gap_before[i + k]) {
        batch = k;
        break;
      }
    }
    if (gap_before[i]) {
      dxl_finder_gap(&single.finder);
      dxl_finder_gap(&batched.finder);
    }
    dxl_packet_t packet;
    for (size_t k = 0; k < batch; k++) {
      digest_result(&single, dxl_finder_push(&single.finder, stream[i + k], &packet), &packet);
    }
    for (size_t pushed = 0; pushed < batch;) {
      uint16_t room;
      uint8_t *slot = dxl_finder_slot(&batched.finder, &room);
      const size_t take = room < batch - pushed ? room : batch - pushed;
      memcpy(slot, &stream[i + pushed], take);
      pushed += take;
      digest_result(&batched, dxl_finder_pushed(&batched.finder, (uint16_t)take, &packet), &packet);
    }
    i += batch;
  }
  printf("batches vs single bytes: %zu results each over %zu bytes\n", single.count, n);
  assert_true(single.count > 300u);
  assert_int_equal(batched.count, single.count);
  assert_memory_equal(batched.digest, single.digest, single.count * sizeof single.digest[0]);
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

/* docs/policy.md "Framing and bus": a Protocol 2.0 frame (FF FF FD 00 ID LEN_L LEN_H ...) is
 * skipped whole by its 16-bit length: a whole 1.0 PING in its data is not a packet; the 1.0
 * packet after it is. Byte by byte and in one batch. */
static const uint8_t protocol2_write_with_a_ping_inside[] = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x0B, 0x00, 0x03, 0x74,
                                                             0x00, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB, 0x2F, 0x8E};

static void test_a_protocol2_frame_is_skipped_whole_with_a_1_0_packet_inside(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  when_bytes_arrive(&run, protocol2_write_with_a_ping_inside, sizeof protocol2_write_with_a_ping_inside);
  assert_int_equal(run.count, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0x03, 0x02, 0x01, 0xF9);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 3, DXL_INST_PING, 0);

  /* the framing step alone says what each byte was */
  dxl_frame_t frame = {0};
  for (size_t i = 0; i < sizeof protocol2_write_with_a_ping_inside; i++) {
    assert_int_equal(dxl_frame_step(&frame, protocol2_write_with_a_ping_inside[i]),
                     i < 3 ? DXL_BYTE_HEADER : DXL_BYTE_PROTOCOL2);
  }
  assert_int_equal(frame.state, DXL_FRAME_SEARCH);
}

/* A 2.0 frame longer than the finder's buffer (LEN 0x0200) is skipped as it comes; one cut by a
 * gap ends with it, and the next 1.0 packet is found. */
static void test_a_long_or_interrupted_protocol2_frame_is_skipped_and_the_next_packet_found(void **state) {
  (void)state;
  finder_run_t run;
  given_finder(&run, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0xFD, 0x00, 0x05, 0x00, 0x02);
  for (unsigned i = 0; i < 0x200u; i++) {
    ARRIVE(&run, (i & 1u) ? 0xFF : 0x05); /* FF 05 FF 05 ...: 1.0 headers if looked at */
  }
  ARRIVE(&run, 0xFF, 0xFF, 0x03, 0x02, 0x01, 0xF9);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 3, DXL_INST_PING, 0);

  given_finder(&run, 0);
  ARRIVE(&run, 0xFF, 0xFF, 0xFD, 0x00, 0x05, 0x40, 0x00, 0x03, 0xFF, 0xFF);
  run.now_ms = DXL_PACKET_GAP_TIMEOUT_MS + 1u;
  ARRIVE(&run, 0xFF, 0xFF, 0x03, 0x02, 0x01, 0xF9);
  assert_int_equal(run.count, 1);
  then_found_packet(&run, 0, 3, DXL_INST_PING, 0);
  assert_true(dxl_finder_idle(&run.finder));
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_a_ping_is_found_when_its_last_byte_arrives),
      cmocka_unit_test(test_parameters_are_reported_in_order),
      cmocka_unit_test(test_extra_leading_header_bytes_are_tolerated),
      cmocka_unit_test(test_the_broadcast_id_is_framed),
      cmocka_unit_test(test_the_finder_resyncs_after_garbage),
      cmocka_unit_test(test_a_bad_packet_takes_the_bytes_its_length_counts),
      cmocka_unit_test(test_a_bad_checksum_is_reported_with_the_packet_fields),
      cmocka_unit_test(test_length_below_2_is_not_a_packet),
      cmocka_unit_test(test_a_gap_of_more_than_100ms_discards_a_partial_packet),
      cmocka_unit_test(test_a_gap_of_exactly_100ms_keeps_a_partial_packet),
      cmocka_unit_test(test_the_gap_is_measured_across_the_wrap_of_the_ms_clock),
      cmocka_unit_test(test_a_gap_leaves_the_finder_idle),
      cmocka_unit_test(test_a_packet_inside_a_garbage_headers_length_is_not_a_packet),
      cmocka_unit_test(test_no_packet_spans_a_gap),
      cmocka_unit_test(test_an_empty_batch_is_no_byte),
      cmocka_unit_test(test_status_packets_of_other_servos_are_framed),
      cmocka_unit_test(test_back_to_back_packets_are_each_found),
      cmocka_unit_test(test_the_longest_packet_length_255_is_found),
      cmocka_unit_test(test_the_candidate_describes_the_packet_before_its_checksum),
      cmocka_unit_test(test_batches_find_what_single_bytes_find),
      cmocka_unit_test(test_checksum_matches_the_manual_examples),
      cmocka_unit_test(test_a_protocol2_frame_is_skipped_whole_with_a_1_0_packet_inside),
      cmocka_unit_test(test_a_long_or_interrupted_protocol2_frame_is_skipped_and_the_next_packet_found),
  };
  return cmocka_run_group_tests_name("packet finder (" AX12_PROFILE_NAME ")", tests, NULL, NULL);
}
