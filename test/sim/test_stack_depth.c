/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Stack depth of the firmware under a representative workload, measured from the stack paint
 * (firmware/hal/startup.S, docs/firmware.md "Stack paint": every byte from _end to RAMEND is
 * STACK_PAINT_BYTE at reset). The workload: every instruction, a full-table READ, a
 * SYNC_WRITE addressed to 30 servos, error cases, EEPROM writes and RESET, and the control
 * loop driving the motor. Prints the figure; fails if the paint was used up or the workload
 * did not run, and, on the ATmega88, if static RAM plus the deepest stack plus what a nested
 * interrupt may add passes RAM_BUDGET_ATMEGA88_BYTES. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include <sim_avr.h>

#include "dxl_protocol.h"
#include "elf_symbols.h"
#include "sim_harness.h"

#define STACK_PAINT_BYTE 0xC5u /* firmware/hal/startup.S */

static void workload(harness_t *h) {
  uint8_t reply[HARNESS_MAX_REPLY];
  assert_int_equal(harness_request(h, 1, DXL_INST_PING, H_NO_PARAMS, 6, reply), 6);
  assert_int_equal(harness_request(h, 1, DXL_INST_READ, HP(0, 50), 56, reply), 56); /* the whole table */
  harness_request(h, 1, DXL_INST_READ, HP(40, 20), 6, reply);     /* Range Error */
  harness_request(h, 1, DXL_INST_WRITE, HP(5, 0), 6, reply);      /* EEPROM: RDT 0 */
  /* 24..35 at once: torque on, LED, margins, slopes, goal, speed, torque limit */
  harness_request(h, 1, DXL_INST_WRITE, HP(24, 1, 1, 1, 1, 32, 32, 0x00, 0x02, 0x00, 0x01, 0xFF, 0x03), 6, reply);
  harness_request(h, 1, DXL_INST_REG_WRITE, HP(30, 0x00, 0x03, 0x00, 0x02), 6, reply);
  harness_request(h, DXL_ID_BROADCAST, DXL_INST_ACTION, H_NO_PARAMS, 0, reply);
  harness_request(h, 1, DXL_INST_WRITE, HP(30, 0xFF, 0x03, 0x00, 0x02), 6, reply); /* drive to the end */
  world_run_until(h->world, h->world->now + sim_ms(30)); /* control loop at full drive */
  /* SYNC_WRITE: Goal Position and Moving Speed for 30 servos (IDs 1..30). */
  uint8_t params[2 + 30 * 5];
  params[0] = 30;
  params[1] = 4;
  for (uint8_t i = 0; i < 30; i++) {
    uint8_t *slot = &params[2 + i * 5];
    slot[0] = (uint8_t)(i + 1);
    slot[1] = (uint8_t)(i * 8);
    slot[2] = 0x01;
    slot[3] = 0x40;
    slot[4] = 0x00;
  }
  harness_request(h, DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE, params, sizeof(params), 0, reply);
  world_run_until(h->world, h->world->now + sim_ms(20));
  /* ID 1 took its slice: Goal Position 0x0100, Moving Speed 0x0040. */
  assert_int_equal(harness_request(h, 1, DXL_INST_READ, HP(30, 4), 10, reply), 10);
  assert_int_equal(reply[5] | reply[6] << 8, 0x0100);
  assert_int_equal(reply[7] | reply[8] << 8, 0x0040);
  harness_request(h, 1, 0x92, HP(0x00, 1, 1, 36), 6, reply);       /* BULK_READ: Instruction Error */
  harness_request(h, 1, 0x7F, H_NO_PARAMS, 6, reply);              /* unknown instruction */
  const uint8_t bad_checksum[] = {0xFF, 0xFF, 0x01, 0x02, 0x01, 0x00};
  uint8_t heard[64];
  harness_exchange(h, bad_checksum, sizeof(bad_checksum), 6, heard, sizeof(heard));
  harness_request(h, 1, DXL_INST_WRITE, HP(47, 1), 6, reply);     /* Lock */
  harness_request(h, 1, DXL_INST_RESET, H_NO_PARAMS, 6, reply);   /* refused while locked (ax12) */
  harness_request(h, 1, DXL_INST_WRITE, HP(24, 0), 6, reply);
  world_run_until(h->world, h->world->now + sim_ms(10));
}

/* At Baud Rate 34 (57 143 bit/s, the manual's section 5): the firmware digests every byte of
 * the 158-byte SYNC_WRITE as it arrives, so the whole workload runs. (At 1 Mbps that packet
 * is a separate test in test_servo.c.) */
#define WORKLOAD_BAUD 34u

/* The ATmega88's RAM budget: static RAM (.data + .bss + .noinit) + deepest stack, at most
 * 768 of its 1024 B, the rest kept for what comes next. NESTING_MARGIN_BYTES is what an
 * interrupt nested in TIMER1_COMPB can add to the measured depth (docs/firmware.md "Build":
 * COMPB's 5 B frame and at most 9 B for the nested ISR). */
#define RAM_BUDGET_ATMEGA88_BYTES 768u
#define NESTING_MARGIN_BYTES 14u

static void measure(const char *profile, const char *mcu) {
  harness_t h;
  harness_open(&h, profile, mcu, WORKLOAD_BAUD);
  servo_t *servo = harness_add_servo(&h, 1, WORKLOAD_BAUD, NULL);
  uint16_t statics_end = 0;
  assert_true(elf_ram_end_of_statics(h.elf, &statics_end));
  harness_boot(&h, 5);
  workload(&h);
  const unsigned depth = servo_stack_depth(servo, statics_end, STACK_PAINT_BYTE);
  const unsigned ramend = servo->avr->ramend;
  const unsigned free_bytes = ramend - statics_end + 1u;
  printf("stack (%s, %s): deepest use %u bytes of the %u bytes between _end (0x%04x) and RAMEND (0x%04x); "
         "%u never touched\n",
         profile, mcu, depth, free_bytes, statics_end, ramend, free_bytes - depth);
  assert_true(depth > 0);
  assert_true(depth < free_bytes); /* some paint is left: the stack did not reach .bss */
  const unsigned static_bytes = statics_end - (servo->avr->ioend + 1u); /* SRAM starts after the I/O space */
  printf("RAM (%s, %s): %u B static + %u B deepest stack + %u B nesting margin = %u B\n", profile, mcu,
         static_bytes, depth, NESTING_MARGIN_BYTES, static_bytes + depth + NESTING_MARGIN_BYTES);
  if (strcmp(mcu, "atmega88") == 0) {
    assert_true(static_bytes + depth + NESTING_MARGIN_BYTES <= RAM_BUDGET_ATMEGA88_BYTES);
  }
  harness_close(&h);
}

static void test_stack_depth_atmega88_ax12(void **state) {
  (void)state;
  measure("ax12", "atmega88");
}

static void test_stack_depth_atmega88_ax12a(void **state) {
  (void)state;
  measure("ax12a", "atmega88");
}

static void test_stack_depth_atmega328p_ax12(void **state) {
  (void)state;
  measure("ax12", "atmega328p");
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_stack_depth_atmega88_ax12),
      cmocka_unit_test(test_stack_depth_atmega88_ax12a),
      cmocka_unit_test(test_stack_depth_atmega328p_ax12),
  };
  return cmocka_run_group_tests_name("sim stack depth", tests, NULL, NULL);
}
