/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The board and the USART model with a small test program (fw/wire_echo.c) instead of the
 * firmware: wire timing of replies, back-to-back bytes, baud changes, the 3-byte receive
 * FIFO and its overrun, the direction pin, the LED, PWM, ADC, EEPROM persistence, several
 * servos on one wire, and an MCU reset. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include <sim_avr.h>

#include "eeprom_store.h"
#include "sim_harness.h"

typedef struct {
  world_t *world;
  master_t *master;
  servo_t *servo[2];
} echo_t;

static void echo_open(echo_t *e, size_t servos, const char *state_path) {
  memset(e, 0, sizeof(*e));
  char err[512];
  e->world = world_create(AX12_WIRE_ECHO_ELF, "atmega88", EEPROM_PROFILE_AX12, err, sizeof(err));
  if (!e->world) {
    fail_msg("%s", err);
  }
  e->master = world_add_master(e->world, 1000000.0);
  for (size_t i = 0; i < servos; i++) {
    e->servo[i] = world_add_servo(e->world, (uint8_t)(i + 1), 1, state_path, err, sizeof(err));
    if (!e->servo[i]) {
      fail_msg("%s", err);
    }
  }
  world_run_until(e->world, sim_ms(1));
  for (size_t i = 0; i < servos; i++) {
    assert_true(servo_listening(e->servo[i]));
  }
}

static void echo_close(echo_t *e) {
  /* Every byte reached every MCU at its exact end cycle, never after. */
  for (size_t i = 0; i < 2; i++) {
    if (e->servo[i]) {
      assert_int_equal(e->servo[i]->board.link.rx_late, 0);
    }
  }
  master_destroy(e->master);
  world_destroy(e->world);
}

/* Sends bytes, runs for `us` microseconds after the last one ends; returns the count received. */
static size_t send_and_wait(echo_t *e, const uint8_t *bytes, size_t count, unsigned us) {
  master_rx_clear(e->master);
  const sim_cycles_t end = master_send(e->master, bytes, count);
  world_run_until(e->world, end + sim_us(us));
  return master_rx_count(e->master);
}

static void test_a_reply_goes_out_back_to_back_at_ten_bit_times_per_byte(void **state) {
  (void)state;
  echo_t e;
  echo_open(&e, 1, NULL);
  const sim_cycles_t request_end = master_send(e.master, (const uint8_t[]){0x10}, 1);
  world_run_until(e.world, request_end + sim_us(200));
  assert_int_equal(master_rx_count(e.master), 2);
  const bus_rx_t *first = master_rx(e.master, 0);
  const bus_rx_t *second = master_rx(e.master, 1);
  assert_int_equal(first->value, 0x10);
  assert_int_equal(second->value, 0x11);
  assert_int_equal(first->flags | second->flags, 0);
  assert_int_equal(first->end - first->start, 160);  /* 10 bits at 1 Mbps, 16 MHz */
  assert_int_equal(second->start, first->end);        /* double-buffered: no gap */
  assert_int_equal(second->end - second->start, 160);
  printf("wire_echo latency: request stop bit end -> reply start bit: %llu cycles\n",
         (unsigned long long)(first->start - request_end));
  assert_true(first->start > request_end);
  /* PD2 went down after the stop bit (TXC), so nothing was cut. */
  world_run_until(e.world, e.world->now + sim_us(50));
  assert_false(e.servo[0]->board.link.driving);
  assert_int_equal(e.world->bus.truncated_bytes, 0);
  assert_int_equal(e.servo[0]->board.link.tx_undriven, 0);
  echo_close(&e);
}

static void test_a_long_reply_keeps_exact_byte_timing(void **state) {
  (void)state;
  echo_t e;
  echo_open(&e, 1, NULL);
  assert_int_equal(send_and_wait(&e, (const uint8_t[]){0xA0}, 1, 1000), 40);
  const bus_rx_t *first = master_rx(e.master, 0);
  for (size_t i = 0; i < 40; i++) {
    const bus_rx_t *b = master_rx(e.master, i);
    assert_int_equal(b->value, i);
    assert_int_equal(b->start, first->start + 160u * i);
  }
  echo_close(&e);
}

static void test_after_a_baud_change_only_the_new_baud_communicates(void **state) {
  (void)state;
  echo_t e;
  echo_open(&e, 1, NULL);
  /* 0x83: answered at 1 Mbps, then UBRR0 = 3 (500 kbit/s). */
  assert_int_equal(send_and_wait(&e, (const uint8_t[]){0x83}, 1, 200), 1);
  assert_int_equal(master_rx(e.master, 0)->value, 0x83);
  /* At the old baud the servo reads garbage and answers it at 500 kbit/s: garbage to us. */
  send_and_wait(&e, (const uint8_t[]){0x10}, 1, 300);
  for (size_t i = 0; i < master_rx_count(e.master); i++) {
    assert_true(master_rx(e.master, i)->flags & BUS_RX_BAUD_MISMATCH);
  }
  master_set_bps(e.master, 500000.0);
  assert_int_equal(send_and_wait(&e, (const uint8_t[]){0x10}, 1, 300), 2);
  assert_int_equal(master_rx(e.master, 0)->value, 0x10);
  assert_int_equal(master_rx(e.master, 1)->value, 0x11);
  assert_int_equal(master_rx(e.master, 0)->end - master_rx(e.master, 0)->start, 320);
  assert_int_equal(master_rx(e.master, 0)->flags, 0);
  echo_close(&e);
}

static void test_the_receiver_holds_three_bytes_while_interrupts_are_off_and_drops_the_fourth(void **state) {
  (void)state;
  echo_t e;
  echo_open(&e, 1, NULL);
  /* 0xC0: the program disables interrupts for 60 us. Then 4 bytes without an answer (>= 0xF0)
   * arrive back to back from 20 us on: all of them end while interrupts are off. */
  const sim_cycles_t end = master_send(e.master, (const uint8_t[]){0xC0}, 1);
  world_run_until(e.world, end + sim_us(20));
  master_send(e.master, (const uint8_t[]){0xF1, 0xF2, 0xF3, 0xF4}, 4);
  world_run_until(e.world, e.world->now + sim_us(200));
  const uart_link_t *link = &e.servo[0]->board.link;
  assert_int_equal(link->rx_overruns, 1);
  assert_int_equal(link->rx_bytes, 1 + 3);
  /* Everything held was read once interrupts came back: the next byte is answered at once. */
  assert_int_equal(send_and_wait(&e, (const uint8_t[]){0x20}, 1, 200), 2);
  assert_int_equal(master_rx(e.master, 0)->value, 0x20);
  echo_close(&e);
}

static void test_bytes_written_while_the_direction_pin_is_low_never_reach_the_wire(void **state) {
  (void)state;
  echo_t e;
  echo_open(&e, 1, NULL);
  assert_int_equal(send_and_wait(&e, (const uint8_t[]){0xD0}, 1, 200), 0);
  assert_int_equal(e.servo[0]->board.link.tx_undriven, 1);
  echo_close(&e);
}

static void test_releasing_the_direction_pin_mid_byte_cuts_it(void **state) {
  (void)state;
  echo_t e;
  echo_open(&e, 1, NULL);
  /* 0xE0: PD2 drops right after the second byte is written, while the first is shifting. */
  assert_int_equal(send_and_wait(&e, (const uint8_t[]){0xE0}, 1, 200), 1);
  assert_true(master_rx(e.master, 0)->flags & BUS_RX_TRUNCATED);
  assert_int_equal(e.world->bus.truncated_bytes, 1);
  echo_close(&e);
}

static void test_led_and_hbridge_follow_the_program(void **state) {
  (void)state;
  echo_t e;
  echo_open(&e, 1, NULL);
  const board_t *board = &e.servo[0]->board;
  const uint64_t before = board->led_transitions;
  send_and_wait(&e, (const uint8_t[]){0x10}, 1, 100);
  assert_int_equal(board->led_transitions, before + 1);
  assert_true(board->led_on);
  assert_non_null(board_led_event(board, board->led_transitions - 1));
  assert_int_equal(board->pwm_a, 0x10);
  assert_int_equal(board->pwm_b, 0xEF);
  echo_close(&e);
}

static uint16_t adc_via_echo(echo_t *e, uint8_t channel) {
  uint8_t cmd = (uint8_t)(0xB0 | channel);
  assert_int_equal(send_and_wait(e, &cmd, 1, 500), 2);
  return (uint16_t)(master_rx(e->master, 0)->value | (master_rx(e->master, 1)->value << 8));
}

static void test_the_adc_reads_the_world(void **state) {
  (void)state;
  echo_t e;
  echo_open(&e, 1, NULL);
  board_t *board = &e.servo[0]->board;
  /* 150 deg = 2500 mV, 9.6 V / 5 = 1920 mV, 25 degC = 750 mV; 10 bits of AVCC = 5 V. */
  assert_int_equal(board_pot_mv(board), 2500);
  assert_int_equal(board_supply_mv(board), 1920);
  assert_int_equal(board_temperature_mv(board), 750);
  const uint16_t pot = adc_via_echo(&e, 0);
  const uint16_t supply = adc_via_echo(&e, 1);
  const uint16_t temp = adc_via_echo(&e, 2);
  /* As silicon converts: floor(mV x 1024 / 5000). */
  assert_int_equal(pot, 512);
  assert_int_equal(supply, 393);
  assert_int_equal(temp, 153);
  board_set_pot_deg(board, 300.0);
  board_set_temperature_c(board, 70.0);
  assert_int_equal(adc_via_echo(&e, 0), 1023);
  assert_int_equal(adc_via_echo(&e, 2), 245); /* 1200 mV */
  static const unsigned mvs[] = {0, 4, 5, 1234, 2499, 4995, 4996};
  for (size_t i = 0; i < sizeof(mvs) / sizeof(mvs[0]); i++) {
    board_set_pot_deg(board, mvs[i] * BOARD_POT_RANGE_DEG / 5000.0);
    const unsigned want = mvs[i] * 1024u / 5000u > 1023u ? 1023u : mvs[i] * 1024u / 5000u;
    assert_int_equal(adc_via_echo(&e, 0), want);
  }
  assert_true(board->adc_conversions >= 5);
  echo_close(&e);
}

static void test_eeprom_writes_reach_the_state_file_before_the_program_can_answer(void **state) {
  (void)state;
  char dir[256];
  harness_tempdir(dir, sizeof(dir));
  char path[512];
  snprintf(path, sizeof(path), "%s/servo-1.eeprom", dir);
  uint8_t file[512];
  char err[256];
  {
    echo_t e;
    echo_open(&e, 1, path);
    /* A fresh state file holds the seeded image. */
    assert_int_equal(eeprom_store_load(path, file, sizeof(file), err, sizeof(err)), 1);
    uint8_t id = 0;
    assert_true(eeprom_store_image_fields(file, sizeof(file), &id, NULL));
    assert_int_equal(id, 1);
    /* 0x9A: EEPROM[10] += 1, answered after the write completed. */
    const uint8_t before = file[10];
    master_rx_clear(e.master);
    const sim_cycles_t end = master_send(e.master, (const uint8_t[]){0x9A}, 1);
    while (master_rx_count(e.master) == 0 && e.world->now < end + sim_ms(10)) {
      world_run_until(e.world, e.world->now + sim_us(10));
    }
    assert_int_equal(master_rx_count(e.master), 1);
    assert_int_equal(master_rx(e.master, 0)->value, (uint8_t)(before + 1));
    /* The program polled EEPE: held for the 3.4 ms a byte takes on silicon. */
    assert_true(master_rx(e.master, 0)->start - end >= SIM_EEPROM_WRITE_CYCLES);
    /* The file already has it (no clean shutdown needed). */
    assert_int_equal(eeprom_store_load(path, file, sizeof(file), err, sizeof(err)), 1);
    assert_int_equal(file[10], (uint8_t)(before + 1));
    assert_int_equal(e.servo[0]->persists, 1);
    echo_close(&e);
  }
  {
    echo_t e;
    echo_open(&e, 1, path);
    assert_int_equal(send_and_wait(&e, (const uint8_t[]){0x9A}, 1, 4000), 1);
    assert_int_equal(master_rx(e.master, 0)->value, (uint8_t)(file[10] + 1));
    echo_close(&e);
  }
  harness_rmdir(dir);
}

static void test_two_servos_answering_at_once_collide_on_the_wire(void **state) {
  (void)state;
  echo_t e;
  echo_open(&e, 2, NULL);
  /* Both answer 0x10 the same number of cycles after the same stop bit. */
  send_and_wait(&e, (const uint8_t[]){0x10}, 1, 200);
  assert_true(master_rx_count(e.master) >= 1);
  for (size_t i = 0; i < master_rx_count(e.master); i++) {
    assert_true(master_rx(e.master, i)->flags & BUS_RX_COLLISION);
  }
  assert_true(e.world->bus.collided_bytes >= 2);
  /* Neither servo heard the other (each drove the bus meanwhile). */
  assert_int_equal(e.servo[0]->board.link.rx_bytes, 1);
  assert_int_equal(e.servo[1]->board.link.rx_bytes, 1);
  echo_close(&e);
}

static void test_a_reset_in_the_middle_of_a_reply_cuts_it_and_the_mcu_starts_over(void **state) {
  (void)state;
  echo_t e;
  echo_open(&e, 1, NULL);
  const sim_cycles_t end = master_send(e.master, (const uint8_t[]){0xA0}, 1);
  world_run_until(e.world, end + sim_us(100));
  servo_reset(e.servo[0]);
  world_run_until(e.world, e.world->now + sim_us(600));
  const size_t got = master_rx_count(e.master);
  assert_true(got > 5 && got < 40);
  assert_false(e.servo[0]->board.link.driving);
  assert_true(servo_listening(e.servo[0]));
  const size_t n = send_and_wait(&e, (const uint8_t[]){0x10}, 1, 200);
  assert_int_equal(n, 2);
  assert_int_equal(master_rx(e.master, 1)->value, 0x11);
  echo_close(&e);
}

static void test_an_idle_servo_costs_little_simulation_time(void **state) {
  (void)state;
  echo_t e;
  echo_open(&e, 1, NULL);
  const uint64_t steps = e.world->steps;
  world_run_until(e.world, e.world->now + sim_ms(100));
  /* Bounded by the step (9 us at 1 Mbps): about 11 000 steps, each cheap. */
  assert_true(e.world->steps - steps <= 100000u / 9u + 2u);
  echo_close(&e);
}

static void test_an_idle_world_takes_long_steps(void **state) {
  (void)state;
  echo_t e;
  echo_open(&e, 1, NULL);
  /* The MCU sleeps; only Timer0's PWM overflows are due, and they cannot wake it. */
  const uint64_t steps = e.world->steps;
  world_run_until(e.world, e.world->now + sim_ms(100));
  assert_true(e.world->steps - steps <= 2u);
  /* ... and the bus still works at exact timing afterwards. */
  assert_int_equal(send_and_wait(&e, (const uint8_t[]){0x10}, 1, 200), 2);
  assert_int_equal(master_rx(e.master, 1)->value, 0x11);
  echo_close(&e);
}

static void test_sleep_cycles_count_the_time_asleep(void **state) {
  (void)state;
  echo_t e;
  echo_open(&e, 1, NULL);
  const servo_t *s = e.servo[0];
  uint64_t asleep = s->sleep_cycles;
  sim_cycles_t t0 = e.world->now;
  world_run_until(e.world, t0 + sim_ms(10));
  const uint64_t idle = s->sleep_cycles - asleep;
  assert_true(idle <= sim_ms(10));
  assert_true(idle >= sim_ms(10) - sim_us(5)); /* the echo program sleeps whenever it is idle */
  /* Echoing a burst keeps it awake part of the time. */
  asleep = s->sleep_cycles;
  t0 = e.world->now;
  uint8_t burst[40];
  memset(burst, 0x20, sizeof(burst));
  send_and_wait(&e, burst, sizeof(burst), 100);
  const uint64_t busy = s->sleep_cycles - asleep;
  assert_true(busy < e.world->now - t0);
  assert_true(busy > 0);
  echo_close(&e);
}

/* Two threads (world_set_threads) give the same wire, cycle for cycle, as one. */
static void run_script(echo_t *e) {
  send_and_wait(e, (const uint8_t[]){0x10}, 1, 200); /* both answer at once: a collision */
  uint8_t burst[24];
  for (size_t i = 0; i < sizeof(burst); i++) {
    burst[i] = (uint8_t)(0x20 + i);
  }
  master_rx_clear(e->master);
  const sim_cycles_t end = master_send(e->master, burst, sizeof(burst));
  world_run_until(e->world, end + sim_us(400));
  world_run_until(e->world, e->world->now + sim_ms(3));
}

static void test_two_threads_give_the_same_wire_as_one(void **state) {
  (void)state;
  echo_t one, two;
  echo_open(&one, 2, NULL);
  echo_open(&two, 2, NULL);
  assert_int_equal(world_set_threads(one.world, 1), 1);
  assert_int_equal(world_set_threads(two.world, 2), 2);
  run_script(&one);
  run_script(&two);
  assert_int_equal(one.world->now, two.world->now);
  assert_int_equal(master_rx_count(one.master), master_rx_count(two.master));
  assert_true(master_rx_count(one.master) > 0);
  for (size_t i = 0; i < master_rx_count(one.master); i++) {
    const bus_rx_t *a = master_rx(one.master, i), *b = master_rx(two.master, i);
    assert_int_equal(a->start, b->start);
    assert_int_equal(a->end, b->end);
    assert_int_equal(a->value, b->value);
    assert_int_equal(a->flags, b->flags);
  }
  for (size_t i = 0; i < 2; i++) {
    assert_int_equal(one.servo[i]->avr->cycle, two.servo[i]->avr->cycle);
    assert_int_equal(one.servo[i]->sleep_cycles, two.servo[i]->sleep_cycles);
    assert_int_equal(one.servo[i]->board.link.rx_bytes, two.servo[i]->board.link.rx_bytes);
    assert_int_equal(one.servo[i]->board.link.tx_bytes, two.servo[i]->board.link.tx_bytes);
  }
  assert_int_equal(one.world->bus.collided_bytes, two.world->bus.collided_bytes);
  echo_close(&one);
  echo_close(&two);
}

int main(void) {
  if (access(AX12_WIRE_ECHO_ELF, R_OK) != 0) {
    fprintf(stderr, "missing %s\n", AX12_WIRE_ECHO_ELF);
    return 1;
  }
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_a_reply_goes_out_back_to_back_at_ten_bit_times_per_byte),
      cmocka_unit_test(test_a_long_reply_keeps_exact_byte_timing),
      cmocka_unit_test(test_after_a_baud_change_only_the_new_baud_communicates),
      cmocka_unit_test(test_the_receiver_holds_three_bytes_while_interrupts_are_off_and_drops_the_fourth),
      cmocka_unit_test(test_bytes_written_while_the_direction_pin_is_low_never_reach_the_wire),
      cmocka_unit_test(test_releasing_the_direction_pin_mid_byte_cuts_it),
      cmocka_unit_test(test_led_and_hbridge_follow_the_program),
      cmocka_unit_test(test_the_adc_reads_the_world),
      cmocka_unit_test(test_eeprom_writes_reach_the_state_file_before_the_program_can_answer),
      cmocka_unit_test(test_two_servos_answering_at_once_collide_on_the_wire),
      cmocka_unit_test(test_a_reset_in_the_middle_of_a_reply_cuts_it_and_the_mcu_starts_over),
      cmocka_unit_test(test_an_idle_servo_costs_little_simulation_time),
      cmocka_unit_test(test_an_idle_world_takes_long_steps),
      cmocka_unit_test(test_sleep_cycles_count_the_time_asleep),
      cmocka_unit_test(test_two_threads_give_the_same_wire_as_one),
  };
  return cmocka_run_group_tests_name("sim wire (board test program)", tests, NULL, NULL);
}
