/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The wire on its own (model/bus/bus.c, no simavr): byte timing, baud mismatch, collisions,
 * a sender that lets go mid-byte, the scheduling contract, and noise (bus_noise.c). */
#include <math.h>
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

/* P(at least one of n bits flips) at rate p. */
static double any_of_bits(double p, unsigned n) { return 1.0 - pow(1.0 - p, (double)n); }

static void test_noise_flips_each_frame_bit_independently_at_the_rate_set(void **state) {
  (void)state;
  const double p = 0.05;
  const unsigned frames = 400000u;
  bus_noise_t noise;
  assert_true(bus_noise_init(&noise, p, 7u));
  unsigned per_bit[BUS_NOISE_FRAME_BITS] = {0};
  unsigned hit = 0;
  unsigned several = 0;
  for (unsigned f = 0; f < frames; f++) {
    const uint16_t mask = bus_noise_next_frame(&noise);
    assert_int_equal(mask & ~0x3FFu, 0);
    hit += mask != 0u;
    several += __builtin_popcount(mask) >= 2;
    for (unsigned bit = 0; bit < BUS_NOISE_FRAME_BITS; bit++) {
      per_bit[bit] += (mask >> bit) & 1u;
    }
  }
  /* Tolerances are 6 to 7 standard errors; the seed makes the run exact anyway. */
  for (unsigned bit = 0; bit < BUS_NOISE_FRAME_BITS; bit++) {
    assert_true(fabs((double)per_bit[bit] / frames - p) <= 0.05 * p);
  }
  assert_true(fabs((double)hit / frames - any_of_bits(p, 10u)) <= 0.005);
  const double p_several = any_of_bits(p, 10u) - 10.0 * p * pow(1.0 - p, 9.0);
  assert_true(fabs((double)several / frames - p_several) <= 0.003);
}

static void test_noise_at_rate_zero_draws_nothing_and_bad_rates_are_refused(void **state) {
  (void)state;
  bus_noise_t noise;
  assert_true(bus_noise_init(&noise, 0.0, 99u));
  for (unsigned f = 0; f < 1000u; f++) {
    assert_int_equal(bus_noise_next_frame(&noise), 0);
  }
  assert_int_equal(noise.prng_state, 99u); /* no draws: nothing else changes either */
  const double bad[] = {-0.001, 1.0, 1.5, NAN, INFINITY, -INFINITY};
  for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
    assert_false(bus_noise_init(&noise, bad[i], 1u));
    assert_true(noise.bit_error_rate == 0.0);
    assert_int_equal(bus_noise_next_frame(&noise), 0);
  }
  bus_t bus;
  bus_init(&bus);
  assert_false(bus_set_noise(&bus, 1.0, 1u));
  assert_true(bus_set_noise(&bus, 0.999, 1u));
  bus_free(&bus);
}

static void test_the_same_seed_gives_the_same_flips(void **state) {
  (void)state;
  bus_noise_t a, b, c;
  assert_true(bus_noise_init(&a, 0.01, 12345u));
  assert_true(bus_noise_init(&b, 0.01, 12345u));
  assert_true(bus_noise_init(&c, 0.01, 12346u));
  unsigned differ = 0;
  for (unsigned f = 0; f < 100000u; f++) {
    const uint16_t mask = bus_noise_next_frame(&a);
    assert_int_equal(mask, bus_noise_next_frame(&b));
    differ += mask != bus_noise_next_frame(&c);
  }
  assert_true(differ > 0u);
}

static void test_noise_corrupts_a_byte_alike_for_every_receiver_and_flags_start_or_stop_flips(void **state) {
  (void)state;
  bus_t bus;
  bus_init(&bus);
  probe_t a, b, c;
  const int na = add_probe(&bus, &a, CYCLES_1MBPS);
  add_probe(&bus, &b, CYCLES_1MBPS);
  add_probe(&bus, &c, CYCLES_1MBPS);
  const double p = 0.02;
  assert_true(bus_set_noise(&bus, p, 3u));
  const unsigned bytes = 20000u;
  unsigned corrupted = 0;
  unsigned value_changed = 0;
  unsigned framing_only = 0;
  for (unsigned i = 0; i < bytes; i++) {
    const uint8_t sent = (uint8_t)(i * 37u);
    bus_send(&bus, na, sent, (sim_cycles_t)i * 200u);
    bus_finalize(&bus, SIM_CYCLES_NEVER - 1);
    assert_int_equal(b.count, 1);
    assert_int_equal(c.count, 1);
    const bus_rx_t *rx = &b.rx[0];
    assert_int_equal(rx->sent, sent);
    assert_int_equal(rx->value, c.rx[0].value);
    assert_int_equal(rx->flags, c.rx[0].flags);
    assert_int_equal(rx->flags & ~BUS_RX_FRAMING_ERROR, 0);
    const bool framing = (rx->flags & BUS_RX_FRAMING_ERROR) != 0u;
    corrupted += rx->value != sent || framing;
    value_changed += rx->value != sent;
    framing_only += framing && rx->value == sent;
    b.count = c.count = 0;
  }
  assert_int_equal(a.count, 0);
  assert_int_equal(bus.noise_corrupted_bytes, corrupted);
  assert_true(value_changed > 0u);
  assert_true(framing_only > 0u); /* a start or stop bit alone leaves the data bits as sent */
  /* 18.3 % of bytes; the tolerance is about 5.5 standard errors. */
  assert_true(fabs((double)corrupted / bytes - any_of_bits(p, 10u)) <= 0.015);
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
      cmocka_unit_test(test_noise_flips_each_frame_bit_independently_at_the_rate_set),
      cmocka_unit_test(test_noise_at_rate_zero_draws_nothing_and_bad_rates_are_refused),
      cmocka_unit_test(test_the_same_seed_gives_the_same_flips),
      cmocka_unit_test(test_noise_corrupts_a_byte_alike_for_every_receiver_and_flags_start_or_stop_flips),
  };
  return cmocka_run_group_tests_name("sim bus", tests, NULL, NULL);
}
