/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The USB adapter model (model/host/usb_adapter.c) on its own, exact in simulated time: the
 * option syntax, the bauds each chip makes, the latency timer and USB packets from bus to
 * host, USB frames from host to bus. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "usb_adapter.h"

static usb_adapter_t make(usb_adapter_kind_t kind, unsigned latency_ms) {
  usb_adapter_t a;
  const usb_adapter_config_t c = {.kind = kind, .latency_ms = latency_ms};
  usb_adapter_init(&a, &c, 0);
  return a;
}

/* Feeds `count` bytes back to back at 1 Mbps (10 us each), the first ending at first_end. */
static sim_cycles_t feed(usb_adapter_t *a, sim_cycles_t first_end, unsigned count) {
  sim_cycles_t end = first_end;
  for (unsigned i = 0; i < count; i++, end += sim_us(10)) {
    usb_adapter_rx_byte(a, end);
  }
  return end - sim_us(10);
}

static void test_parse_accepts_kinds_and_latencies(void **state) {
  (void)state;
  usb_adapter_config_t c;
  char err[160];
  assert_true(usb_adapter_parse("u2d2", &c, err, sizeof(err)));
  assert_int_equal(c.kind, USB_ADAPTER_U2D2);
  assert_int_equal(c.latency_ms, 1);
  assert_true(usb_adapter_parse("u2d2:16", &c, err, sizeof(err)));
  assert_int_equal(c.latency_ms, 16);
  assert_true(usb_adapter_parse("usb2dynamixel:255", &c, err, sizeof(err)));
  assert_int_equal(c.kind, USB_ADAPTER_USB2DYNAMIXEL);
  assert_int_equal(c.latency_ms, 255);
  assert_true(usb_adapter_parse("wire", &c, err, sizeof(err)));
  assert_int_equal(c.kind, USB_ADAPTER_WIRE);
}

static void test_parse_rejects_bad_values_with_a_reason(void **state) {
  (void)state;
  static const char *const bad[] = {"foo", "u2d2:0", "u2d2:256", "u2d2:", "u2d2:1x", "u2d2:-1", "u2d2: 1",
                                    "wire:5", "", "U2D2", "u2d2:99999999999999999999"};
  for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
    usb_adapter_config_t c = {.kind = USB_ADAPTER_WIRE, .latency_ms = 7};
    char err[160] = "";
    assert_false(usb_adapter_parse(bad[i], &c, err, sizeof(err)));
    assert_true(strlen(err) > 10);
    assert_int_equal(c.latency_ms, 7); /* untouched */
  }
}

static void test_every_ax12_baud_is_exact_on_both_chips(void **state) {
  (void)state;
  for (unsigned reg = 0; reg <= 254; reg++) {
    const double bps = 2000000.0 / (reg + 1u);
    assert_float_equal(usb_adapter_actual_bps(USB_ADAPTER_U2D2, bps), bps, bps * 1e-9);
    assert_float_equal(usb_adapter_actual_bps(USB_ADAPTER_USB2DYNAMIXEL, bps), bps, bps * 1e-9);
  }
}

static void test_other_bauds_take_the_divisor_steps(void **state) {
  (void)state;
  /* 12 MHz / (n + k/8) on the hi-speed chip (the U2D2 e-manual's table lists these). */
  assert_float_equal(usb_adapter_actual_bps(USB_ADAPTER_U2D2, 57600), 12e6 / 208.375, 1e-6);
  assert_float_equal(usb_adapter_actual_bps(USB_ADAPTER_U2D2, 115200), 12e6 / 104.125, 1e-6);
  assert_float_equal(usb_adapter_actual_bps(USB_ADAPTER_U2D2, 4500000), 12e6 / 2.625, 1e-6);
  assert_float_equal(usb_adapter_actual_bps(USB_ADAPTER_U2D2, 6000000), 6e6, 1e-6);
  /* 3 MHz / (n + k/8) on the FT232R. */
  assert_float_equal(usb_adapter_actual_bps(USB_ADAPTER_USB2DYNAMIXEL, 115200), 3e6 / 26.0, 1e-6);
  assert_float_equal(usb_adapter_actual_bps(USB_ADAPTER_USB2DYNAMIXEL, 57600), 3e6 / 52.125, 1e-6);
  assert_float_equal(usb_adapter_actual_bps(USB_ADAPTER_USB2DYNAMIXEL, 3000000), 3e6, 1e-6);
  /* Between divisors 1 and 2 only 1 and 1.5 exist. */
  assert_float_equal(usb_adapter_actual_bps(USB_ADAPTER_USB2DYNAMIXEL, 2500000), 2e6, 1e-6);
  /* Above the chip's maximum Linux's ftdi_sio sets 9600. */
  assert_float_equal(usb_adapter_actual_bps(USB_ADAPTER_USB2DYNAMIXEL, 4000000), 3e6 / 312.5, 1e-6);
  assert_float_equal(usb_adapter_actual_bps(USB_ADAPTER_U2D2, 12500000), 12e6 / 1250.0, 1e-6);
  assert_float_equal(usb_adapter_actual_bps(USB_ADAPTER_WIRE, 123456), 123456, 0);
}

static void test_a_reply_waits_for_the_latency_timer(void **state) {
  (void)state;
  usb_adapter_t a = make(USB_ADAPTER_U2D2, 16);
  const sim_cycles_t last = feed(&a, sim_us(5000), 8);
  usb_adapter_packet_t p;
  assert_false(usb_adapter_pop(&a, &p));
  assert_int_equal(usb_adapter_next_release(&a), sim_ms(16));
  usb_adapter_advance(&a, sim_ms(16) - 1u);
  assert_false(usb_adapter_pop(&a, &p));
  usb_adapter_advance(&a, sim_ms(16));
  assert_true(usb_adapter_pop(&a, &p));
  assert_int_equal(p.at, sim_ms(16));
  assert_int_equal(p.bytes, 8);
  assert_false(usb_adapter_pop(&a, &p));
  assert_int_equal(a.stats.in_timer_packets, 1);
  assert_int_equal(a.stats.latency_wait_max, sim_ms(16) - last);
  assert_int_equal(usb_adapter_next_release(&a), SIM_CYCLES_NEVER);
}

static void test_the_timer_runs_free_between_replies(void **state) {
  (void)state;
  usb_adapter_t a = make(USB_ADAPTER_U2D2, 16);
  usb_adapter_advance(&a, sim_ms(100)); /* idle: status-only packets at 16, 32 .. 96 ms */
  assert_int_equal(a.stats.in_status_only, 6);
  usb_adapter_rx_byte(&a, sim_ms(100));
  usb_adapter_advance(&a, sim_ms(200));
  usb_adapter_packet_t p;
  assert_true(usb_adapter_pop(&a, &p));
  assert_int_equal(p.at, sim_ms(112)); /* on the grid, not 16 ms after the byte */
  /* A byte ending exactly at an expiry misses it. */
  usb_adapter_rx_byte(&a, sim_ms(208));
  usb_adapter_advance(&a, sim_ms(230));
  assert_true(usb_adapter_pop(&a, &p));
  assert_int_equal(p.at, sim_ms(224));
}

static void test_a_reply_across_an_expiry_arrives_in_two_packets(void **state) {
  (void)state;
  usb_adapter_t a = make(USB_ADAPTER_U2D2, 1);
  feed(&a, sim_us(960), 8); /* ends at 960 .. 1030 us; the one ending at 1000 us misses */
  usb_adapter_advance(&a, sim_ms(3));
  usb_adapter_packet_t p;
  assert_true(usb_adapter_pop(&a, &p));
  assert_int_equal(p.at, sim_ms(1));
  assert_int_equal(p.bytes, 4);
  assert_true(usb_adapter_pop(&a, &p));
  assert_int_equal(p.at, sim_ms(2));
  assert_int_equal(p.bytes, 4);
}

static void test_a_full_packet_leaves_at_once_and_restarts_the_timer(void **state) {
  (void)state;
  usb_adapter_t a = make(USB_ADAPTER_USB2DYNAMIXEL, 16);
  const sim_cycles_t last = feed(&a, sim_us(100), 63); /* 62 fill a 64-byte packet */
  usb_adapter_packet_t p;
  assert_true(usb_adapter_pop(&a, &p));
  assert_int_equal(p.bytes, 62);
  assert_int_equal(p.at, last - sim_us(10));
  assert_false(usb_adapter_pop(&a, &p));
  assert_int_equal(usb_adapter_next_release(&a), p.at + sim_ms(16));
  usb_adapter_advance(&a, p.at + sim_ms(16));
  assert_true(usb_adapter_pop(&a, &p));
  assert_int_equal(p.bytes, 1);
  assert_int_equal(a.stats.in_full_packets, 1);
  /* The hi-speed chip fills 510-byte packets. */
  usb_adapter_t h = make(USB_ADAPTER_U2D2, 16);
  feed(&h, sim_us(10), 510);
  assert_true(usb_adapter_pop(&h, &p));
  assert_int_equal(p.bytes, 510);
}

static void test_wire_hands_over_each_byte_at_its_end(void **state) {
  (void)state;
  usb_adapter_t a = make(USB_ADAPTER_WIRE, 0);
  usb_adapter_rx_byte(&a, 12345);
  usb_adapter_packet_t p;
  assert_true(usb_adapter_pop(&a, &p));
  assert_int_equal(p.at, 12345);
  assert_int_equal(p.bytes, 1);
  assert_int_equal(usb_adapter_next_release(&a), SIM_CYCLES_NEVER);
  assert_int_equal(usb_adapter_tx_write(&a, 777, 6), 777);
  assert_int_equal(usb_adapter_tx_queue_limit(&a), 0);
}

static void test_a_write_waits_for_the_next_usb_frame(void **state) {
  (void)state;
  usb_adapter_t h = make(USB_ADAPTER_U2D2, 1);
  assert_int_equal(usb_adapter_tx_write(&h, 1, 6), sim_us(125));
  assert_int_equal(usb_adapter_tx_write(&h, sim_us(250), 6), sim_us(250));
  assert_int_equal(usb_adapter_tx_write(&h, sim_us(251), 600), sim_us(375));
  assert_int_equal(h.stats.out_packets, 1 + 1 + 2);
  usb_adapter_t f = make(USB_ADAPTER_USB2DYNAMIXEL, 1);
  assert_int_equal(usb_adapter_tx_write(&f, 1, 100), sim_ms(1));
  assert_int_equal(f.stats.out_packets, 2);
  assert_int_equal(f.stats.frame_wait_total, sim_ms(1) - 1u);
  assert_int_equal(usb_adapter_tx_queue_limit(&f), 4096 + 256);
  assert_int_equal(usb_adapter_tx_queue_limit(&h), 4096 + 1024);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_parse_accepts_kinds_and_latencies),
      cmocka_unit_test(test_parse_rejects_bad_values_with_a_reason),
      cmocka_unit_test(test_every_ax12_baud_is_exact_on_both_chips),
      cmocka_unit_test(test_other_bauds_take_the_divisor_steps),
      cmocka_unit_test(test_a_reply_waits_for_the_latency_timer),
      cmocka_unit_test(test_the_timer_runs_free_between_replies),
      cmocka_unit_test(test_a_reply_across_an_expiry_arrives_in_two_packets),
      cmocka_unit_test(test_a_full_packet_leaves_at_once_and_restarts_the_timer),
      cmocka_unit_test(test_wire_hands_over_each_byte_at_its_end),
      cmocka_unit_test(test_a_write_waits_for_the_next_usb_frame),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
