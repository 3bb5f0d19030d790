/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The firmware ELF in simavr on the simulated bus: reply timing on the wire (Return Delay
 * Time), baud and ID changes and RESET (reply with the old settings), EEPROM state across
 * restarts, a corrupt image, several servos on one wire, every ELF variant. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "dxl_image.h"
#include "dxl_protocol.h"
#include "eeprom_store.h"
#include "sim_harness.h"

#define STATUS_LEN(params) (6u + (params))

static const uint8_t ping_reply_id1[] = {0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC};

static void expect_bytes(const uint8_t *got, size_t got_len, const uint8_t *want, size_t want_len) {
  if (got_len != want_len || memcmp(got, want, want_len) != 0) {
    char a[512];
    char b[512];
    fail_msg("expected %s, heard %s", packet_hex(want, want_len, a, sizeof(a)), packet_hex(got, got_len, b, sizeof(b)));
  }
}

static void expect_status(harness_t *h, const uint8_t *got, size_t got_len, uint8_t id, uint8_t error,
                          const uint8_t *params, size_t count) {
  (void)h;
  uint8_t want[64];
  const size_t n = packet_encode(want, id, error, params, count);
  expect_bytes(got, got_len, want, n);
}

static void open_one(harness_t *h, const char *state_dir) {
  harness_open(h, "ax12", "atmega88", 1);
  harness_add_servo(h, 1, 1, state_dir);
  harness_boot(h, 5);
}

/* Writes one byte at addr of servo id and checks the reply. */
static void write_byte(harness_t *h, uint8_t id, uint8_t addr, uint8_t value) {
  uint8_t reply[64];
  const size_t n = harness_request(h, id, DXL_INST_WRITE, HP(addr, value), STATUS_LEN(0), reply);
  expect_status(h, reply, n, id, 0, H_NO_PARAMS);
}

static uint8_t read_byte(harness_t *h, uint8_t id, uint8_t addr) {
  uint8_t reply[64];
  const size_t n = harness_request(h, id, DXL_INST_READ, HP(addr, 1), STATUS_LEN(1), reply);
  assert_int_equal(n, STATUS_LEN(1));
  assert_int_equal(reply[4], 0);
  return reply[5];
}

/* One request and its reply as the master saw them on the wire: cycles from the end of the
 * request's last stop bit to the start of the reply's first start bit, and the longest pause
 * between two reply bytes (0: back to back). */
typedef struct {
  sim_cycles_t latency;
  sim_cycles_t longest_pause;
} wire_timing_t;

static wire_timing_t request_timing(harness_t *h, uint8_t id, uint8_t instruction, const uint8_t *params, size_t count,
                                    size_t reply_len) {
  uint8_t packet[16];
  const size_t len = packet_encode(packet, id, instruction, params, count);
  master_rx_clear(h->master);
  const sim_cycles_t request_end = master_send(h->master, packet, len);
  uint8_t reply[64];
  world_run_until(h->world, request_end);
  const size_t n = harness_exchange(h, NULL, 0, reply_len, reply, sizeof(reply));
  assert_int_equal(n, reply_len);
  assert_int_equal(master_rx_count(h->master), reply_len);
  assert_int_equal(reply[4], 0); /* no error */
  wire_timing_t t = {master_rx(h->master, 0)->start - request_end, 0};
  for (size_t i = 0; i < reply_len; i++) {
    const bus_rx_t *b = master_rx(h->master, i);
    assert_int_equal(b->flags, 0);
    if (i != 0) {
      const sim_cycles_t pause = b->start - master_rx(h->master, i - 1)->end;
      t.longest_pause = pause > t.longest_pause ? pause : t.longest_pause;
    }
  }
  return t;
}

/* docs/policy.md "Framing and bus": a Protocol 2.0 frame is skipped whole, by the RX
 * interrupt's sniff and the finder alike: a whole 1.0 PING of this servo in its data is not
 * answered (at once, and after a gap), and the 1.0 PING after it is. */
static void test_a_protocol2_frame_with_a_1_0_ping_inside_is_not_answered(void **state) {
  (void)state;
  harness_t h;
  open_one(&h, NULL);
  static const uint8_t frame[] = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x0B, 0x00, 0x03, 0x74,
                                  0x00, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB, 0x2F, 0x8E};
  uint8_t reply[64];
  for (int round = 0; round < 3; round++) {
    assert_int_equal(harness_exchange(&h, frame, sizeof frame, 0, reply, sizeof reply), 0);
    const size_t n = harness_request(&h, 1, DXL_INST_PING, H_NO_PARAMS, STATUS_LEN(0), reply);
    expect_bytes(reply, n, ping_reply_id1, sizeof(ping_reply_id1));
  }
  assert_int_equal(harness_exchange(&h, frame, sizeof frame, 0, reply, sizeof reply), 0);
  world_run_until(h.world, h.world->now + sim_ms(150)); /* past the gap: nothing either */
  assert_int_equal(harness_exchange(&h, NULL, 0, 0, reply, sizeof reply), 0);
  harness_close(&h);
}

static void test_ping_is_answered_on_the_wire(void **state) {
  (void)state;
  harness_t h;
  open_one(&h, NULL);
  uint8_t reply[64];
  const size_t n = harness_request(&h, 1, DXL_INST_PING, H_NO_PARAMS, STATUS_LEN(0), reply);
  expect_bytes(reply, n, ping_reply_id1, sizeof(ping_reply_id1));
  /* Back to back at 1 Mbps: 160 cycles a byte. */
  for (size_t i = 0; i < n; i++) {
    const bus_rx_t *b = master_rx(h.master, i);
    assert_int_equal(b->end - b->start, 160);
    assert_int_equal(b->flags, 0);
    if (i) {
      assert_int_equal(b->start, master_rx(h.master, i - 1)->end);
    }
  }
  harness_close(&h);
}

/* PING, a READ of Present Position and a WRITE of the LED (RAM; Status Return Level 2, the
 * default): the reply starts 2 us x Return Delay Time after the request's stop bit, within
 * 2 us, at every timer phase (12 requests each, spread over the control tick's period). */
typedef struct {
  const char *name;
  uint8_t instruction;
  uint8_t params[2];
  uint8_t count;
  uint8_t reply_params;
} timed_request_t;

static void test_reply_starts_two_us_times_return_delay_time_after_the_stop_bit(void **state) {
  (void)state;
  harness_t h;
  open_one(&h, NULL);
  static const uint8_t rdts[] = {0, 1, 10, 250, 254};
  static const timed_request_t kinds[] = {
      {"PING", DXL_INST_PING, {0, 0}, 0, 0},
      {"READ 2", DXL_INST_READ, {36, 2}, 2, 2},
      {"WRITE 1", DXL_INST_WRITE, {25, 0}, 2, 0},
      {"ACTION", DXL_INST_ACTION, {0, 0}, 0, 0},
  };
  enum { KINDS = sizeof kinds / sizeof kinds[0], RDTS = sizeof rdts };
  sim_cycles_t lo[KINDS][RDTS];
  sim_cycles_t hi[KINDS][RDTS];
  sim_cycles_t pause[KINDS][RDTS];
  sim_cycles_t pause_lo[KINDS][RDTS];
  for (size_t r = 0; r < RDTS; r++) {
    write_byte(&h, 1, 5, rdts[r]);
    for (size_t k = 0; k < KINDS; k++) {
      lo[k][r] = SIM_CYCLES_NEVER;
      hi[k][r] = 0;
      pause[k][r] = 0;
      pause_lo[k][r] = SIM_CYCLES_NEVER;
      for (unsigned phase = 0; phase < 12; phase++) {
        if (kinds[k].instruction == DXL_INST_ACTION) {
          uint8_t reply[64]; /* something to run: ACTION is handed to the main loop, not armed */
          (void)harness_request(&h, 1, DXL_INST_REG_WRITE, HP(25, 0), STATUS_LEN(0), reply);
        }
        world_run_until(h.world, h.world->now + sim_us(37u * phase + 3u));
        const wire_timing_t t =
            request_timing(&h, 1, kinds[k].instruction, kinds[k].params, kinds[k].count, STATUS_LEN(kinds[k].reply_params));
        lo[k][r] = t.latency < lo[k][r] ? t.latency : lo[k][r];
        hi[k][r] = t.latency > hi[k][r] ? t.latency : hi[k][r];
        pause[k][r] = t.longest_pause > pause[k][r] ? t.longest_pause : pause[k][r];
        pause_lo[k][r] = t.longest_pause < pause_lo[k][r] ? t.longest_pause : pause_lo[k][r];
      }
      const double expected = 2.0 * rdts[r] * SIM_CYCLES_PER_US;
      printf("%-7s RDT %3u: reply starts %llu..%llu cycles (%.2f..%.2f us) after the request's stop bit; "
             "2 us x RDT = %u us; error %+.2f..%+.2f us; longest pause inside the reply %.2f..%.2f us\n",
             kinds[k].name, rdts[r], (unsigned long long)lo[k][r], (unsigned long long)hi[k][r],
             sim_cycles_to_us(lo[k][r]), sim_cycles_to_us(hi[k][r]), 2u * rdts[r],
             ((double)lo[k][r] - expected) / SIM_CYCLES_PER_US, ((double)hi[k][r] - expected) / SIM_CYCLES_PER_US,
             sim_cycles_to_us(pause_lo[k][r]), sim_cycles_to_us(pause[k][r]));
    }
  }
  for (size_t k = 0; k < KINDS; k++) {
    for (size_t r = 0; r < RDTS; r++) {
      const double expected = 2.0 * rdts[r] * SIM_CYCLES_PER_US;
      if (rdts[r] != 0 && ((double)lo[k][r] < expected - 2.0 * SIM_CYCLES_PER_US ||
                           (double)hi[k][r] > expected + 2.0 * SIM_CYCLES_PER_US)) {
        fail_msg("%s, RDT %u: the reply starts %.2f..%.2f us after the stop bit, not within 2 us of %u us",
                 kinds[k].name, rdts[r], sim_cycles_to_us(lo[k][r]), sim_cycles_to_us(hi[k][r]), 2u * rdts[r]);
      }
    }
  }
  harness_close(&h);
}

/* A master may send its next packet as soon as a status packet ends (a controller on the bus
 * does; a PC behind a USB adapter cannot): it is answered at the Return Delay Time like any
 * other, whatever the gap after the servo's own reply. */
static void test_a_packet_right_after_the_servos_reply_is_answered_on_time(void **state) {
  (void)state;
  harness_t h;
  open_one(&h, NULL);
  static const unsigned gaps_us[] = {0, 1, 5, 10, 20, 50, 100, 200, 400};
  for (size_t g = 0; g < sizeof gaps_us / sizeof gaps_us[0]; g++) {
    for (unsigned phase = 0; phase < 8; phase++) {
      uint8_t packet[16];
      const size_t len = packet_encode(packet, 1, DXL_INST_WRITE, HP(28, (uint8_t)(32 + phase)));
      master_rx_clear(h.master);
      const sim_cycles_t write_end = master_send(h.master, packet, len);
      world_run_until(h.world, write_end + sim_us(37u * phase));
      while (master_rx_count(h.master) < STATUS_LEN(0)) {
        world_run_until(h.world, h.world->now + 8u);
      }
      const sim_cycles_t reply_end = master_rx(h.master, STATUS_LEN(0) - 1u)->end;
      world_run_until(h.world, reply_end + sim_us(gaps_us[g]));
      const wire_timing_t t = request_timing(&h, 1, DXL_INST_READ, HP(36, 2), STATUS_LEN(2));
      const double error_us = sim_cycles_to_us(t.latency) - 500.0; /* factory RDT 250: 500 us */
      if (error_us < -2.0 || error_us > 2.0) {
        fail_msg("READ %u us after the servo's reply (phase %u): answered %.2f us after its stop bit, not 500",
                 gaps_us[g], phase, sim_cycles_to_us(t.latency));
      }
    }
  }
  harness_close(&h);
}

/* The ready PING reply (answered by the RX interrupt) keeps the Return Delay Time after a
 * packet that got no reply: another servo's, or a broadcast PING of profile ax12a. */
static void ping_after_silent_packet(const char *profile, const uint8_t *silent, size_t silent_len) {
  harness_t h;
  harness_open(&h, profile, "atmega88", 1);
  harness_add_servo(&h, 1, 1, NULL);
  harness_boot(&h, 5);
  for (unsigned round = 0; round < 3; round++) {
    uint8_t reply[64];
    assert_int_equal(harness_exchange(&h, silent, silent_len, 0, reply, sizeof reply), 0);
    const wire_timing_t t = request_timing(&h, 1, DXL_INST_PING, H_NO_PARAMS, STATUS_LEN(0));
    const double error_us = sim_cycles_to_us(t.latency) - 500.0; /* factory RDT 250: 500 us */
    if (error_us < -2.0 || error_us > 2.0) {
      fail_msg("%s, round %u: a PING after a packet with no reply was answered %.2f us after its stop bit, not 500",
               profile, round, sim_cycles_to_us(t.latency));
    }
  }
  harness_close(&h);
}

static void test_a_ping_after_a_packet_with_no_reply_keeps_the_return_delay_time(void **state) {
  (void)state;
  static const uint8_t broadcast_ping[] = {0xFF, 0xFF, 0xFE, 0x02, 0x01, 0xFE};
  static const uint8_t read_of_servo_2[] = {0xFF, 0xFF, 0x02, 0x04, 0x02, 0x24, 0x02, 0xD1};
  ping_after_silent_packet("ax12a", broadcast_ping, sizeof broadcast_ping);
  ping_after_silent_packet("ax12", read_of_servo_2, sizeof read_of_servo_2);
  ping_after_silent_packet("ax12a", read_of_servo_2, sizeof read_of_servo_2);
}

/* A reply the main loop composes after the packet (here a broadcast PING, which the 2006
 * manual answers; also RESET, unknown instructions and Checksum Errors: docs/firmware.md
 * "Reply timing") starts 2 us x Return Delay Time after the stop bit, within half a
 * microsecond (one Timer1 tick), when that leaves the main loop time to compose it; at small
 * delays it starts once composed, never early. */
static void test_a_reply_the_main_loop_composes_starts_on_time_when_the_delay_allows(void **state) {
  (void)state;
  harness_t h;
  open_one(&h, NULL);
  static const uint8_t rdts[] = {0, 10, 100, 250, 254};
  for (size_t r = 0; r < sizeof rdts; r++) {
    write_byte(&h, 1, 5, rdts[r]);
    sim_cycles_t lo = SIM_CYCLES_NEVER;
    sim_cycles_t hi = 0;
    for (unsigned phase = 0; phase < 12; phase++) {
      world_run_until(h.world, h.world->now + sim_us(37u * phase + 3u));
      const wire_timing_t t = request_timing(&h, DXL_ID_BROADCAST, DXL_INST_PING, NULL, 0, STATUS_LEN(0));
      lo = t.latency < lo ? t.latency : lo;
      hi = t.latency > hi ? t.latency : hi;
    }
    const double expected = 2.0 * rdts[r] * SIM_CYCLES_PER_US;
    printf("broadcast PING RDT %3u: reply starts %.2f..%.2f us after the stop bit; error %+.2f..%+.2f us\n", rdts[r],
           sim_cycles_to_us(lo), sim_cycles_to_us(hi), ((double)lo - expected) / SIM_CYCLES_PER_US,
           ((double)hi - expected) / SIM_CYCLES_PER_US);
    assert_true((double)lo >= expected - 0.5 * SIM_CYCLES_PER_US);
    if (rdts[r] >= 100) {
      assert_true((double)hi <= expected + 0.5 * SIM_CYCLES_PER_US);
    }
  }
  harness_close(&h);
}

/* A READ whose checksum never comes: its reply was armed (and, streamed, prepared) at the
 * byte before; after a gap of more than 100 ms the partial packet is gone without a reply, and
 * the next PING gets the ready reply, byte for byte, at every Return Delay Time mode. */
static void test_a_packet_cut_before_its_checksum_is_dropped_and_the_next_answered(void **state) {
  (void)state;
  harness_t h;
  open_one(&h, NULL);
  static const uint8_t rdts[] = {0, 3, 250};
  for (size_t r = 0; r < sizeof rdts; r++) {
    write_byte(&h, 1, 5, rdts[r]);
    uint8_t read[16];
    const size_t len = packet_encode(read, 1, DXL_INST_READ, HP(36, 2));
    uint8_t reply[64];
    assert_int_equal(harness_exchange(&h, read, len - 1u, 0, reply, sizeof reply), 0); /* silence */
    world_run_until(h.world, h.world->now + sim_ms(120));
    const size_t n = harness_request(&h, 1, DXL_INST_PING, H_NO_PARAMS, STATUS_LEN(0), reply);
    expect_bytes(reply, n, ping_reply_id1, sizeof(ping_reply_id1));
  }
  harness_close(&h);
}

static void test_a_baud_change_replies_at_the_old_baud_then_only_the_new_one_works(void **state) {
  (void)state;
  harness_t h;
  open_one(&h, NULL);
  uint8_t reply[64];
  size_t n = harness_request(&h, 1, DXL_INST_WRITE, HP(4, 34), STATUS_LEN(0), reply);
  expect_bytes(reply, n, ping_reply_id1, sizeof(ping_reply_id1));
  assert_int_equal(master_rx(h.master, 0)->end - master_rx(h.master, 0)->start, 160); /* at 1 Mbps */
  /* At 1 Mbps now: garbage or nothing, never a status packet. */
  n = harness_request(&h, 1, DXL_INST_PING, H_NO_PARAMS, 0, reply);
  for (size_t i = 0; i < master_rx_count(h.master); i++) {
    assert_true(master_rx(h.master, i)->flags & BUS_RX_BAUD_MISMATCH);
  }
  /* 2 000 000 / 35 = 57 143 bit/s: 280 cycles a bit. */
  master_set_baud_reg(h.master, 34);
  n = harness_request(&h, 1, DXL_INST_PING, H_NO_PARAMS, STATUS_LEN(0), reply);
  expect_bytes(reply, n, ping_reply_id1, sizeof(ping_reply_id1));
  assert_int_equal(master_rx(h.master, 0)->end - master_rx(h.master, 0)->start, 2800);
  assert_int_equal(master_rx(h.master, 0)->flags, 0);
  /* 57 600 bit/s (what a client asks for) is within 3 % of it. */
  master_set_bps(h.master, 57600.0);
  n = harness_request(&h, 1, DXL_INST_PING, H_NO_PARAMS, STATUS_LEN(0), reply);
  expect_bytes(reply, n, ping_reply_id1, sizeof(ping_reply_id1));
  harness_close(&h);
}

static void test_an_id_change_is_answered_with_the_old_id(void **state) {
  (void)state;
  harness_t h;
  open_one(&h, NULL);
  uint8_t reply[64];
  size_t n = harness_request(&h, 1, DXL_INST_WRITE, HP(3, 5), STATUS_LEN(0), reply);
  expect_bytes(reply, n, ping_reply_id1, sizeof(ping_reply_id1));
  n = harness_request(&h, 5, DXL_INST_PING, H_NO_PARAMS, STATUS_LEN(0), reply);
  expect_status(&h, reply, n, 5, 0, H_NO_PARAMS);
  n = harness_request(&h, 1, DXL_INST_PING, H_NO_PARAMS, 0, reply);
  assert_int_equal(n, 0);
  harness_close(&h);
}

static void test_reset_is_answered_with_the_old_id_then_factory_settings_apply(void **state) {
  (void)state;
  harness_t h;
  open_one(&h, NULL);
  uint8_t reply[64];
  write_byte(&h, 1, 3, 7);
  size_t n = harness_request(&h, 7, DXL_INST_RESET, H_NO_PARAMS, STATUS_LEN(0), reply);
  expect_status(&h, reply, n, 7, 0, H_NO_PARAMS);
  n = harness_request(&h, 7, DXL_INST_PING, H_NO_PARAMS, 0, reply);
  assert_int_equal(n, 0);
  n = harness_request(&h, 1, DXL_INST_PING, H_NO_PARAMS, STATUS_LEN(0), reply);
  expect_bytes(reply, n, ping_reply_id1, sizeof(ping_reply_id1));
  harness_close(&h);
}

static void test_settings_survive_a_restart(void **state) {
  (void)state;
  char dir[256];
  harness_tempdir(dir, sizeof(dir));
  harness_t h;
  open_one(&h, dir);
  assert_int_equal(read_byte(&h, 1, 5), 250);
  write_byte(&h, 1, 5, 10);
  write_byte(&h, 1, 17, 0x24); /* Alarm LED */
  harness_close(&h);

  open_one(&h, dir);
  assert_int_equal(read_byte(&h, 1, 5), 10);
  assert_int_equal(read_byte(&h, 1, 17), 0x24);
  harness_close(&h);
  harness_rmdir(dir);
}

/* docs/policy.md "Power-up": an image whose check passes but whose items are out of range
 * (crafted, or a 16-bit value torn under a matching check) boots with those items at their
 * factory defaults and the others as stored, and never drives the motor unasked. */
static void test_a_crafted_image_boots_with_its_items_in_range_and_the_motor_still(void **state) {
  (void)state;
  char dir[256];
  harness_tempdir(dir, sizeof(dir));
  char path[512];
  eeprom_store_path(path, sizeof(path), dir, 1);
  uint8_t eeprom[512];
  eeprom_store_seed(eeprom, sizeof(eeprom), EEPROM_PROFILE_AX12, 1, 1);
  uint8_t area[CT_EEPROM_SIZE];
  memcpy(area, dxl_image_settings(eeprom), CT_EEPROM_SIZE);
  area[CT_ADDR_ID] = 254;
  area[CT_ADDR_BAUD_RATE] = 255;
  area[CT_ADDR_RETURN_DELAY_TIME] = 255;
  area[CT_ADDR_CW_ANGLE_LIMIT] = 0x00; /* 54784 */
  area[CT_ADDR_CW_ANGLE_LIMIT + 1] = 0xD6;
  area[CT_ADDR_CCW_ANGLE_LIMIT + 1] = 0x07; /* 1023 torn to 2047 */
  area[CT_ADDR_STATUS_RETURN_LEVEL] = 9;
  area[CT_ADDR_ALARM_LED] = 0x25; /* in range: kept */
  dxl_image_build(eeprom, area);
  char err[256];
  assert_int_equal(eeprom_store_save(path, eeprom, sizeof(eeprom), err, sizeof(err)), 0);

  harness_t h;
  harness_open(&h, "ax12", "atmega88", 1);
  harness_add_servo(&h, 1, 1, dir);
  harness_boot(&h, 5);
  uint8_t reply[64];
  const size_t n = harness_request(&h, 1, DXL_INST_READ, HP(0, CT_EEPROM_SIZE), STATUS_LEN(CT_EEPROM_SIZE), reply);
  assert_int_equal(n, STATUS_LEN(CT_EEPROM_SIZE));
  const uint8_t *t = &reply[5];
  assert_int_equal(t[CT_ADDR_ID], 1);
  assert_int_equal(t[CT_ADDR_BAUD_RATE], 1);
  assert_int_equal(t[CT_ADDR_RETURN_DELAY_TIME], 250);
  assert_int_equal(t[CT_ADDR_CW_ANGLE_LIMIT] | (t[CT_ADDR_CW_ANGLE_LIMIT + 1] << 8), 0);
  assert_int_equal(t[CT_ADDR_CCW_ANGLE_LIMIT] | (t[CT_ADDR_CCW_ANGLE_LIMIT + 1] << 8), 1023);
  assert_int_equal(t[CT_ADDR_STATUS_RETURN_LEVEL], 2);
  assert_int_equal(t[CT_ADDR_ALARM_LED], 0x25);
  /* Half a second later: torque off, no drive, no motion. */
  const uint16_t start = (uint16_t)(read_byte(&h, 1, CT_ADDR_PRESENT_POSITION) |
                                    (read_byte(&h, 1, CT_ADDR_PRESENT_POSITION + 1) << 8));
  world_run_until(h.world, h.world->now + sim_ms(500));
  assert_int_equal(read_byte(&h, 1, CT_ADDR_TORQUE_ENABLE), 0);
  assert_int_equal(read_byte(&h, 1, CT_ADDR_PRESENT_LOAD), 0);
  assert_int_equal(read_byte(&h, 1, CT_ADDR_PRESENT_LOAD + 1), 0);
  assert_int_equal(read_byte(&h, 1, CT_ADDR_MOVING), 0);
  const uint16_t end = (uint16_t)(read_byte(&h, 1, CT_ADDR_PRESENT_POSITION) |
                                  (read_byte(&h, 1, CT_ADDR_PRESENT_POSITION + 1) << 8));
  assert_true(end + 2u >= start && end <= start + 2u);
  harness_close(&h);
  harness_rmdir(dir);
}

static void test_a_corrupt_image_boots_to_factory_defaults_and_is_repaired(void **state) {
  (void)state;
  char dir[256];
  harness_tempdir(dir, sizeof(dir));
  char path[512];
  eeprom_store_path(path, sizeof(path), dir, 1);
  uint8_t eeprom[512];
  eeprom_store_seed(eeprom, sizeof(eeprom), EEPROM_PROFILE_AX12, 7, 1);
  for (unsigned slot = 0; slot < DXL_IMAGE_SLOTS; slot++) {
    uint8_t *const bytes = &eeprom[dxl_image_slot_offset((uint8_t)slot)];
    bytes[DXL_IMAGE_OFS_TABLE + 5] = 20; /* RDT 20 ... */
    bytes[DXL_IMAGE_OFS_CRC] ^= 0x5A;    /* ... under a broken CRC, in both slots */
  }
  char err[256];
  assert_int_equal(eeprom_store_save(path, eeprom, sizeof(eeprom), err, sizeof(err)), 0);

  harness_t h;
  harness_open(&h, "ax12", "atmega88", 1);
  harness_add_servo(&h, 1, 1, dir);
  harness_boot(&h, 5);
  uint8_t reply[64];
  size_t n = harness_request(&h, 7, DXL_INST_PING, H_NO_PARAMS, 0, reply);
  assert_int_equal(n, 0);
  n = harness_request(&h, 1, DXL_INST_PING, H_NO_PARAMS, STATUS_LEN(0), reply);
  expect_bytes(reply, n, ping_reply_id1, sizeof(ping_reply_id1));
  assert_int_equal(read_byte(&h, 1, 5), 250);
  world_run_until(h.world, h.world->now + sim_ms(200));
  harness_close(&h);
  /* The firmware wrote the defaults back; the state file has them. */
  assert_int_equal(eeprom_store_load(path, eeprom, sizeof(eeprom), err, sizeof(err)), 1);
  uint8_t id = 0;
  uint8_t baud = 0;
  assert_true(eeprom_store_image_fields(eeprom, sizeof(eeprom), &id, &baud));
  assert_int_equal(id, 1);
  assert_int_equal(baud, 1);
  assert_int_equal(eeprom[DXL_IMAGE_OFS_TABLE + 5], 250);
  harness_rmdir(dir);
}

static void test_a_fresh_state_file_is_seeded_with_the_id_and_baud_asked_for(void **state) {
  (void)state;
  char dir[256];
  harness_tempdir(dir, sizeof(dir));
  harness_t h;
  harness_open(&h, "ax12", "atmega88", 34);
  harness_add_servo(&h, 9, 34, dir);
  harness_boot(&h, 5);
  uint8_t reply[64];
  size_t n = harness_request(&h, 9, DXL_INST_PING, H_NO_PARAMS, STATUS_LEN(0), reply);
  expect_status(&h, reply, n, 9, 0, H_NO_PARAMS);
  master_set_baud_reg(h.master, 1);
  n = harness_request(&h, 9, DXL_INST_PING, H_NO_PARAMS, 0, reply);
  assert_true(n == 0 || (master_rx(h.master, 0)->flags & BUS_RX_BAUD_MISMATCH));
  harness_close(&h);
  char path[512];
  eeprom_store_path(path, sizeof(path), dir, 9);
  assert_int_equal(access(path, R_OK), 0);
  harness_rmdir(dir);
}

static void test_servos_on_one_wire_answer_their_own_ids_and_collide_on_broadcast_ping(void **state) {
  (void)state;
  harness_t h;
  harness_open(&h, "ax12", "atmega88", 1);
  for (uint8_t id = 1; id <= 3; id++) {
    harness_add_servo(&h, id, 1, NULL);
  }
  harness_boot(&h, 5);
  uint8_t reply[64];
  for (uint8_t id = 1; id <= 3; id++) {
    const size_t n = harness_request(&h, id, DXL_INST_PING, H_NO_PARAMS, STATUS_LEN(0), reply);
    expect_status(&h, reply, n, id, 0, H_NO_PARAMS);
  }
  /* The 2006 manual answers broadcast PING: three replies at the same moment. */
  const uint64_t collided = h.world->bus.collided_bytes;
  const size_t n = harness_request(&h, DXL_ID_BROADCAST, DXL_INST_PING, H_NO_PARAMS, STATUS_LEN(0), reply);
  char text[256];
  printf("broadcast PING, 3 servos: the master heard %s\n", packet_hex(reply, n, text, sizeof(text)));
  assert_true(h.world->bus.collided_bytes > collided);
  assert_true(n > 0);
  assert_true(master_rx(h.master, 0)->flags & BUS_RX_COLLISION);
  harness_close(&h);
}

static void test_a_sync_write_to_30_servos_at_1_mbps_is_applied(void **state) {
  (void)state;
  harness_t h;
  open_one(&h, NULL);
  /* Goal Position and Moving Speed for IDs 1..30: 158 bytes back to back. */
  uint8_t params[2 + 30 * 5];
  params[0] = 30;
  params[1] = 4;
  for (uint8_t i = 0; i < 30; i++) {
    uint8_t *slot = &params[2 + i * 5];
    slot[0] = (uint8_t)(i + 1);
    slot[1] = (uint8_t)(0x10 + i);
    slot[2] = 0x01;
    slot[3] = 0x40;
    slot[4] = 0x00;
  }
  uint8_t reply[64];
  assert_int_equal(harness_request(&h, DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE, params, sizeof(params), 0, reply), 0);
  const size_t n = harness_request(&h, 1, DXL_INST_READ, HP(30, 4), STATUS_LEN(4), reply);
  expect_status(&h, reply, n, 1, 0, HP(0x10, 0x01, 0x40, 0x00));
  harness_close(&h);
}

/* The RX interrupt's sniff holds a packet's bytes up to fixed bounds, past which the main
 * loop's finder takes them (docs/firmware.md "Receive"): at most 7 header bytes FF .. FF (so
 * up to 5 extra 0xFF before the ID) and LENGTH at most 96. A packet on either side of each
 * bound is answered or applied the same; within them a READ's reply is armed (it starts
 * within 40 cycles at Return Delay Time 0). */
static void test_packets_on_both_sides_of_the_sniff_bounds_are_handled_alike(void **state) {
  (void)state;
  harness_t h;
  open_one(&h, NULL);
  write_byte(&h, 1, 5, 0); /* Return Delay Time 0 */
  for (size_t extra = 0; extra <= 8; extra++) {
    uint8_t bytes[32];
    memset(bytes, 0xFF, extra);
    const size_t len = extra + packet_encode(bytes + extra, 1, DXL_INST_READ, HP(3, 1));
    master_rx_clear(h.master);
    const sim_cycles_t request_end = master_send(h.master, bytes, len);
    world_run_until(h.world, request_end);
    uint8_t reply[64];
    const size_t n = harness_exchange(&h, NULL, 0, STATUS_LEN(1), reply, sizeof reply);
    expect_status(&h, reply, n, 1, 0, HP(1));
    const sim_cycles_t latency = master_rx(h.master, 0)->start - request_end;
    if (latency > 40) { /* the sniff holds any number of them: none reach the ring */
      fail_msg("READ behind %zu extra 0xFF: reply %llu cycles after the stop bit, not armed", extra,
               (unsigned long long)latency);
    }
  }
  /* Broadcast SYNC_WRITEs of LENGTH 96 (held whole) and 97 (the finder's), each followed at
   * once by a READ of what it wrote to servo 1. */
  static const struct {
    uint8_t servos, data_len;
  } shapes[] = {{23, 3}, {31, 2}};
  for (size_t k = 0; k < 2; k++) {
    uint8_t params[2 + 31 * 4];
    size_t count = 0;
    params[count++] = 26; /* the Compliance Margins (and CW Compliance Slope) */
    params[count++] = shapes[k].data_len;
    for (uint8_t i = 0; i < shapes[k].servos; i++) {
      params[count++] = (uint8_t)(i + 1);
      for (uint8_t b = 0; b < shapes[k].data_len; b++) {
        params[count++] = (uint8_t)(0x20 + k + b);
      }
    }
    uint8_t bytes[160];
    size_t len = packet_encode(bytes, DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE, params, count);
    assert_int_equal(bytes[3], 94u + 2u + k); /* LENGTH */
    len += packet_encode(bytes + len, 1, DXL_INST_READ, HP(26, shapes[k].data_len));
    uint8_t reply[64];
    const size_t n = harness_exchange(&h, bytes, len, STATUS_LEN(shapes[k].data_len), reply, sizeof reply);
    uint8_t want[3] = {(uint8_t)(0x20 + k), (uint8_t)(0x21 + k), (uint8_t)(0x22 + k)};
    expect_status(&h, reply, n, 1, 0, want, shapes[k].data_len);
  }
  harness_close(&h);
}

/* Another servo's packet is parsed to its end by its LENGTH and ignored (docs/policy.md
 * "Framing and bus"): the RX ISR skips its bytes from the LENGTH on. What follows it at once
 * is heard from its first byte (a READ right behind it is armed), whatever its parameters hold
 * (a READ of this servo inside them is no packet), and a packet cut short swallows the next
 * bytes only within the 100 ms gap rule. */
static void send_then_read(harness_t *h, const uint8_t *before, size_t before_len, bool expect_answer) {
  uint8_t bytes[160];
  memcpy(bytes, before, before_len);
  const size_t len = before_len + packet_encode(bytes + before_len, 1, DXL_INST_READ, HP(3, 1));
  master_rx_clear(h->master);
  const sim_cycles_t request_end = master_send(h->master, bytes, len);
  world_run_until(h->world, request_end);
  uint8_t reply[64];
  const size_t n = harness_exchange(h, NULL, 0, expect_answer ? STATUS_LEN(1) : 0, reply, sizeof reply);
  if (!expect_answer) {
    assert_int_equal(n, 0);
    return;
  }
  expect_status(h, reply, n, 1, 0, HP(1));
  const sim_cycles_t latency = master_rx(h->master, 0)->start - request_end;
  if (latency > 40) {
    fail_msg("READ right behind %zu bytes: reply %llu cycles after the stop bit, not armed", before_len,
             (unsigned long long)latency);
  }
}

static void test_another_servos_packet_is_skipped_by_its_length(void **state) {
  (void)state;
  harness_t h;
  open_one(&h, NULL);
  write_byte(&h, 1, 5, 0); /* Return Delay Time 0 */
  /* Instructions and status packets of servo 7, LENGTH 2..96; the parameters hide a READ of
   * servo 1 (FF FF 01 04 02 03 01 F4). */
  uint8_t hidden[8];
  (void)packet_encode(hidden, 1, DXL_INST_READ, HP(3, 1));
  static const uint8_t param_counts[] = {0, 1, 2, 8, 20, 94};
  for (size_t k = 0; k < sizeof param_counts; k++) {
    uint8_t params[94];
    for (size_t i = 0; i < param_counts[k]; i++) {
      params[i] = hidden[i % sizeof hidden];
    }
    uint8_t other[128];
    const size_t other_len = packet_encode(other, 7, DXL_INST_WRITE, params, param_counts[k]);
    send_then_read(&h, other, other_len, true);
  }
  /* Cut short: FF FF 07 LENGTH 5 and two of its five remaining bytes. */
  static const uint8_t cut[] = {0xFF, 0xFF, 0x07, 0x05, 0x03, 0x19};
  assert_int_equal(harness_exchange(&h, cut, sizeof cut, 0, NULL, 0), 0);
  /* 90 ms on (harness_exchange's silence): the gap is not over, so the READ's first three
   * bytes complete the packet and the rest is no packet. */
  send_then_read(&h, NULL, 0, false);
  /* After a gap of more than 100 ms the partial packet is gone: the READ is heard whole. */
  assert_int_equal(harness_exchange(&h, cut, sizeof cut, 0, NULL, 0), 0);
  world_run_until(h.world, h.world->now + sim_ms(20));
  send_then_read(&h, NULL, 0, true);
  harness_close(&h);
}

/* The sniff reads a header without storing it (uart_rx.S): what it drops, skips or waits for
 * must be what the finder would. Each READ of servo 1 below is armed (replied within 40
 * cycles) unless said otherwise. */
static void test_the_sniff_reads_a_header_as_the_finder_would(void **state) {
  (void)state;
  harness_t h;
  open_one(&h, NULL);
  write_byte(&h, 1, 5, 0); /* Return Delay Time 0 */
  /* Bytes that cannot start a header, an FF followed by one, a header with LENGTH 1. */
  static const uint8_t garbage[] = {0x00, 0x42, 0xFF, 0x01, 0xFF, 0xFF, 0x07, 0x01};
  send_then_read(&h, garbage, sizeof garbage, true);
  /* Another servo's packet longer than the sniff would hold (LENGTH 122) is skipped by its
   * LENGTH too: the READ of servo 1 in its parameters is not answered, the next one is. */
  uint8_t hidden[8];
  (void)packet_encode(hidden, 1, DXL_INST_READ, HP(3, 1));
  uint8_t params[120];
  for (size_t i = 0; i < sizeof params; i++) {
    params[i] = hidden[i % sizeof hidden];
  }
  uint8_t other[160];
  const size_t other_len = packet_encode(other, 7, DXL_INST_WRITE, params, sizeof params);
  send_then_read(&h, other, other_len, true);
  /* A header that pauses (a client writing it byte by byte): the READ completes 50 ms after
   * its FF FF 01; after 150 ms the header is gone, and the READ that follows is heard whole. */
  for (int pause_ms = 50; pause_ms <= 150; pause_ms += 100) {
    master_rx_clear(h.master);
    world_run_until(h.world, master_send(h.master, hidden, 3) + sim_ms((unsigned)pause_ms));
    const uint8_t *rest = pause_ms < 100 ? hidden + 3 : hidden;
    const size_t rest_len = pause_ms < 100 ? sizeof hidden - 3 : sizeof hidden;
    const sim_cycles_t request_end = master_send(h.master, rest, rest_len);
    world_run_until(h.world, request_end);
    uint8_t reply[64];
    const size_t n = harness_exchange(&h, NULL, 0, STATUS_LEN(1), reply, sizeof reply);
    expect_status(&h, reply, n, 1, 0, HP(1));
    if (master_rx(h.master, 0)->start - request_end > 40) {
      fail_msg("READ after a header paused %d ms: not armed", pause_ms);
    }
  }
  harness_close(&h);
}

static void test_every_firmware_variant_boots_and_answers(void **state) {
  (void)state;
  static const char *const profiles[] = {"ax12", "ax12a"};
  static const char *const mcus[] = {"atmega88", "atmega328p"};
  for (size_t p = 0; p < 2; p++) {
    for (size_t m = 0; m < 2; m++) {
      harness_t h;
      harness_open(&h, profiles[p], mcus[m], 1);
      harness_add_servo(&h, 1, 1, NULL);
      harness_boot(&h, 5);
      uint8_t reply[64];
      const size_t n = harness_request(&h, 1, DXL_INST_READ, HP(0, 3), STATUS_LEN(3), reply);
      assert_int_equal(n, STATUS_LEN(3));
      assert_int_equal(reply[5], 12); /* Model Number 12 */
      assert_int_equal(reply[6], 0);
      harness_close(&h);
    }
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_ping_is_answered_on_the_wire),
      cmocka_unit_test(test_reply_starts_two_us_times_return_delay_time_after_the_stop_bit),
      cmocka_unit_test(test_a_packet_right_after_the_servos_reply_is_answered_on_time),
      cmocka_unit_test(test_a_ping_after_a_packet_with_no_reply_keeps_the_return_delay_time),
      cmocka_unit_test(test_a_reply_the_main_loop_composes_starts_on_time_when_the_delay_allows),
      cmocka_unit_test(test_a_packet_cut_before_its_checksum_is_dropped_and_the_next_answered),
      cmocka_unit_test(test_a_baud_change_replies_at_the_old_baud_then_only_the_new_one_works),
      cmocka_unit_test(test_an_id_change_is_answered_with_the_old_id),
      cmocka_unit_test(test_reset_is_answered_with_the_old_id_then_factory_settings_apply),
      cmocka_unit_test(test_settings_survive_a_restart),
      cmocka_unit_test(test_a_corrupt_image_boots_to_factory_defaults_and_is_repaired),
      cmocka_unit_test(test_a_crafted_image_boots_with_its_items_in_range_and_the_motor_still),
      cmocka_unit_test(test_a_fresh_state_file_is_seeded_with_the_id_and_baud_asked_for),
      cmocka_unit_test(test_servos_on_one_wire_answer_their_own_ids_and_collide_on_broadcast_ping),
      cmocka_unit_test(test_a_sync_write_to_30_servos_at_1_mbps_is_applied),
      cmocka_unit_test(test_packets_on_both_sides_of_the_sniff_bounds_are_handled_alike),
      cmocka_unit_test(test_another_servos_packet_is_skipped_by_its_length),
      cmocka_unit_test(test_the_sniff_reads_a_header_as_the_finder_would),
      cmocka_unit_test(test_every_firmware_variant_boots_and_answers),
      cmocka_unit_test(test_a_protocol2_frame_with_a_1_0_ping_inside_is_not_answered),
  };
  return cmocka_run_group_tests_name("sim servo (firmware ELF)", tests, NULL, NULL);
}
