/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The wire on its own (model/sim/bus.c, no simavr): byte timing, baud mismatch, collisions,
 * a sender that lets go mid-byte, and the scheduling contract. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "bus.h"

#define CYCLES_1MBPS 16.0

typedef struct {
  double cycles_per_bit;
  bus_rx_t rx[64];
  size_t count;
} probe_t;

static double probe_cycles_per_bit(void *ctx) { return ((probe_t *)ctx)->cycles_per_bit; }

static void probe_deliver(void *ctx, const bus_rx_t *rx) {
  probe_t *p = ctx;
  assert_true(p->count < 64);
  p->rx[p->count++] = *rx;
}

static int add_probe(bus_t *bus, probe_t *p, double cycles_per_bit) {
  memset(p, 0, sizeof(*p));
  p->cycles_per_bit = cycles_per_bit;
  const bus_node_ops_t ops = {.cycles_per_bit = probe_cycles_per_bit, .deliver = probe_deliver, .ctx = p};
  return bus_add_node(bus, "probe", &ops);
}

static void test_bytes_take_ten_bit_times_and_arrive_at_the_end_of_their_stop_bit(void **state) {
  (void)state;
  bus_t bus;
  bus_init(&bus);
  probe_t a, b;
  const int na = add_probe(&bus, &a, CYCLES_1MBPS);
  add_probe(&bus, &b, CYCLES_1MBPS);
  assert_int_equal(bus_send(&bus, na, 0x12, 1000), 1160);
  assert_int_equal(bus_send(&bus, na, 0x34, 1000), 1320); /* queued behind the first */
  assert_int_equal(bus_send(&bus, na, 0x56, 2000), 2160);
  assert_int_equal(bus_next_finalize(&bus), 1160 - BUS_FINALIZE_MARGIN);
  bus_finalize(&bus, 1160 - BUS_FINALIZE_MARGIN - 1);
  assert_int_equal(b.count, 0);
  bus_finalize(&bus, 1160 - BUS_FINALIZE_MARGIN);
  assert_int_equal(b.count, 1);
  bus_finalize(&bus, 3000);
  assert_int_equal(b.count, 3);
  assert_int_equal(a.count, 0); /* a sender never hears itself */
  assert_int_equal(b.rx[0].start, 1000);
  assert_int_equal(b.rx[0].end, 1160);
  assert_int_equal(b.rx[1].start, 1160);
  assert_int_equal(b.rx[1].end, 1320);
  assert_int_equal(b.rx[2].start, 2000);
  assert_int_equal(b.rx[2].value, 0x56);
  assert_int_equal(b.rx[0].flags, 0);
  bus_free(&bus);
}

static void test_a_receiver_within_3_percent_decodes_every_byte(void **state) {
  (void)state;
  bus_t bus;
  bus_init(&bus);
  probe_t a, b;
  const int na = add_probe(&bus, &a, CYCLES_1MBPS);
  add_probe(&bus, &b, CYCLES_1MBPS * 1.029);
  for (unsigned v = 0; v < 256; v++) {
    bus_send(&bus, na, (uint8_t)v, 0);
    bus_finalize(&bus, SIM_CYCLES_NEVER - 1);
    assert_int_equal(b.rx[b.count - 1].value, v);
    assert_int_equal(b.rx[b.count - 1].flags, 0);
    b.count = 0;
  }
  bus_free(&bus);
}

static void test_a_receiver_off_by_more_than_3_percent_never_gets_the_byte_sent(void **state) {
  (void)state;
  const double ratios[] = {1.031, 0.969, 1.2, 2.0, 1000000.0 / 57600.0};
  for (size_t r = 0; r < sizeof(ratios) / sizeof(ratios[0]); r++) {
    bus_t bus;
    bus_init(&bus);
    probe_t a, b;
    const int na = add_probe(&bus, &a, CYCLES_1MBPS);
    add_probe(&bus, &b, CYCLES_1MBPS * ratios[r]);
    for (unsigned v = 0; v < 256; v++) {
      bus_send(&bus, na, (uint8_t)v, (sim_cycles_t)v * 10000u);
      bus_finalize(&bus, SIM_CYCLES_NEVER - 1);
      assert_int_equal(b.count, 1);
      assert_int_not_equal(b.rx[0].value, v);
      assert_true(b.rx[0].flags & BUS_RX_BAUD_MISMATCH);
      b.count = 0;
    }
    bus_free(&bus);
  }
}

static void test_a_slow_receiver_samples_the_fast_waveform(void **state) {
  (void)state;
  /* 0x0F at 1 Mbps seen by a receiver at a quarter of the speed: its first sample (1.5 of its
   * bits, cycle 96) falls on the sender's data bit 5 (0), the others after the byte (idle). */
  const bus_byte_t b = {.start = 0, .end = 160, .cut_at = SIM_CYCLES_NEVER, .cycles_per_bit = 16.0, .value = 0x0F,
                        .frame_bits = 10};
  assert_int_equal(bus_decode(&b, 1, 0, 64.0), 0xFE);
  /* The same rate reads the byte. */
  assert_int_equal(bus_decode(&b, 1, 0, 16.0), 0x0F);
  /* Twice as fast: data bits 0..7 sampled at 1.5..8.5 half-bits = bits 0,1,1,2,2,3,3,4 of the
   * sender's frame: start bit, then 1, 1, 1, 1, 1, 1, 1 (0x0F's low bits). */
  assert_int_equal(bus_decode(&b, 1, 0, 8.0), 0xFE);
}

static void test_overlapping_senders_collide_and_the_line_reads_wired_and(void **state) {
  (void)state;
  bus_t bus;
  bus_init(&bus);
  probe_t a, c, rx;
  const int na = add_probe(&bus, &a, CYCLES_1MBPS);
  const int nc = add_probe(&bus, &c, CYCLES_1MBPS);
  add_probe(&bus, &rx, CYCLES_1MBPS);
  bus_send(&bus, na, 0xF3, 0);
  bus_send(&bus, nc, 0x3F, 0);
  bus_finalize(&bus, 1000);
  /* One frame on the line, not two: the receiver is busy with the first. */
  assert_int_equal(rx.count, 1);
  assert_true(rx.rx[0].flags & BUS_RX_COLLISION);
  assert_int_equal(rx.rx[0].value, 0x33);
  /* Each sender hears the other's byte through the collision. */
  assert_int_equal(a.count, 1);
  assert_int_equal(c.count, 1);
  assert_true(a.rx[0].flags & BUS_RX_COLLISION);
  assert_int_equal(bus.collided_bytes, 2);
  bus_free(&bus);
}

static void test_a_byte_starting_in_the_last_half_stop_bit_does_not_collide(void **state) {
  (void)state;
  bus_t bus;
  bus_init(&bus);
  probe_t a, c, rx;
  const int na = add_probe(&bus, &a, CYCLES_1MBPS);
  const int nc = add_probe(&bus, &c, CYCLES_1MBPS);
  add_probe(&bus, &rx, CYCLES_1MBPS);
  bus_send(&bus, na, 0x12, 0);   /* ends at 160, stop bit sampled by 152 */
  bus_send(&bus, nc, 0x34, 153); /* starts after that */
  bus_finalize(&bus, 1000);
  assert_int_equal(rx.count, 2);
  assert_int_equal(rx.rx[0].value, 0x12);
  assert_int_equal(rx.rx[1].value, 0x34);
  assert_int_equal(rx.rx[0].flags | rx.rx[1].flags, 0);
  bus_free(&bus);
}

static void test_a_sender_that_releases_mid_byte_leaves_an_idle_line(void **state) {
  (void)state;
  bus_t bus;
  bus_init(&bus);
  probe_t a, rx;
  const int na = add_probe(&bus, &a, CYCLES_1MBPS);
  add_probe(&bus, &rx, CYCLES_1MBPS);
  bus_send(&bus, na, 0x00, 0);
  bus_send(&bus, na, 0x00, 0); /* would start at 160 */
  bus_release(&bus, na, 40);   /* during data bit 1 (32..48) */
  bus_finalize(&bus, 1000);
  assert_int_equal(rx.count, 1); /* the second byte never reached the wire */
  assert_true(rx.rx[0].flags & BUS_RX_TRUNCATED);
  assert_int_equal(rx.rx[0].value, 0xFE); /* bit 0 was driven, bits 1..7 read idle */
  /* Releasing during the stop bit costs nothing. */
  bus_send(&bus, na, 0x5A, 2000);
  bus_release(&bus, na, 2155);
  bus_finalize(&bus, 3000);
  assert_int_equal(rx.count, 2);
  assert_int_equal(rx.rx[1].value, 0x5A);
  assert_int_equal(rx.rx[1].flags, 0);
  bus_free(&bus);
}

static void test_the_step_bound_keeps_every_byte_ending_after_the_step(void **state) {
  (void)state;
  bus_t bus;
  bus_init(&bus);
  probe_t a, b;
  add_probe(&bus, &a, CYCLES_1MBPS);
  const int nb = add_probe(&bus, &b, CYCLES_1MBPS);
  assert_int_equal(bus_lookahead(&bus), 160 - 2 * BUS_FINALIZE_MARGIN);
  /* A byte started anywhere in a step of that length ends, minus the margin, after it. */
  const sim_cycles_t now = 5000;
  const sim_cycles_t end = bus_send(&bus, nb, 0, now);
  assert_true(end - BUS_FINALIZE_MARGIN > now + bus_lookahead(&bus));
  /* A faster node shortens the step. */
  b.cycles_per_bit = 8.0;
  bus_baud_changed(&bus);
  assert_int_equal(bus_lookahead(&bus), 80 - 2 * BUS_FINALIZE_MARGIN);
  bus_free(&bus);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_bytes_take_ten_bit_times_and_arrive_at_the_end_of_their_stop_bit),
      cmocka_unit_test(test_a_receiver_within_3_percent_decodes_every_byte),
      cmocka_unit_test(test_a_receiver_off_by_more_than_3_percent_never_gets_the_byte_sent),
      cmocka_unit_test(test_a_slow_receiver_samples_the_fast_waveform),
      cmocka_unit_test(test_overlapping_senders_collide_and_the_line_reads_wired_and),
      cmocka_unit_test(test_a_byte_starting_in_the_last_half_stop_bit_does_not_collide),
      cmocka_unit_test(test_a_sender_that_releases_mid_byte_leaves_an_idle_line),
      cmocka_unit_test(test_the_step_bound_keeps_every_byte_ending_after_the_step),
  };
  return cmocka_run_group_tests_name("sim bus", tests, NULL, NULL);
}
