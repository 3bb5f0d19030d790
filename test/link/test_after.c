/* What follows a handled packet, in order (firmware/link/dxl_after.h), on the host with a
 * recording port: a write's reply starts without waiting for the EEPROM, whose store starts at
 * the commit; RESET's defaults are stored after its reply; a new baud applies after the
 * reply; nothing else happens. Each packet goes through the core as the firmware's main loop
 * hands it on: prepare, reply start, commit, reply end. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "dxl_after.h"
#include "dxl_after_port.h"
#include "dxl_protocol.h"
#include "dxl_servo.h"
#include "dxl_table.h"

/* The recording port: the board functions in the order the policy calls them, with the
 * reply's place marked by the test. */
typedef struct {
  char log[256];
  uint8_t stored_id;   /* ID in the last stored table */
  uint8_t stored_baud; /* Baud Rate in the last stored table */
} port_t;

static void log_event(port_t *p, const char *event) { strncat(p->log, event, sizeof p->log - strlen(p->log) - 1u); }

void dxl_after_port_persist(void *port, const uint8_t *table) {
  port_t *p = port;
  p->stored_id = table[CT_ADDR_ID];
  p->stored_baud = table[CT_ADDR_BAUD_RATE];
  log_event(p, "store ");
}

void dxl_after_port_set_baud(void *port, uint8_t baud_register) {
  char text[16];
  snprintf(text, sizeof text, "baud=%u ", baud_register);
  log_event(port, text);
}

#if DXL_HAS_BOOTLOADER
void dxl_after_port_enter_bootloader(void *port) {
  log_event(port, "bootloader ");
}
#endif

/* A packet to servo 1 handled as the main loop does (firmware/app/main.c on_packet,
 * service_reply): prepared, its reply started (when there is one), committed, then what must
 * wait for the reply's end. Returns the response. */
static dxl_response_t handled(dxl_servo_t *servo, port_t *port, uint8_t instruction, const uint8_t *params,
                              uint8_t count) {
  const dxl_packet_t packet = {1, instruction, count, params, 0};
  dxl_response_t response;
  dxl_servo_prepare(servo, &packet, &response);
  if (response.length != 0) {
    log_event(port, "reply ");
  }
  dxl_servo_commit(servo, &response);
  dxl_after_commit(servo, response.after, port);
  if (response.length != 0) {
    log_event(port, "end ");
  }
  dxl_after_reply(servo, response.after, port);
  return response;
}

static void given_servo(dxl_servo_t *servo, port_t *port) {
  memset(port, 0, sizeof *port);
  dxl_servo_power_up(servo, NULL, 512);
}

static void test_a_write_of_the_eeprom_area_is_answered_then_stored_while_the_reply_goes_out(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  handled(&servo, &port, DXL_INST_WRITE, (const uint8_t[]){CT_ADDR_RETURN_DELAY_TIME, 10}, 2);
  assert_string_equal(port.log, "reply store end ");
  assert_false(dxl_after_waits_for_reply(DXL_AFTER_PERSIST));
}

static void test_a_new_id_is_stored_and_the_reply_still_carries_the_old_one(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  const dxl_response_t r = handled(&servo, &port, DXL_INST_WRITE, (const uint8_t[]){CT_ADDR_ID, 7}, 2);
  assert_string_equal(port.log, "reply store end ");
  assert_int_equal(port.stored_id, 7);
  assert_int_equal(r.bytes[2], 1); /* FF FF ID: the old one */
}

static void test_a_new_baud_is_stored_at_once_and_applied_after_the_reply(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  const dxl_response_t r = handled(&servo, &port, DXL_INST_WRITE, (const uint8_t[]){CT_ADDR_BAUD_RATE, 34}, 2);
  assert_string_equal(port.log, "reply store end baud=34 ");
  assert_int_equal(port.stored_baud, 34);
  assert_true(dxl_after_waits_for_reply(r.after));
}

static void test_reset_answers_first_then_stores_the_factory_defaults_and_their_baud(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  servo.table[CT_ADDR_ID] = 1;
  servo.table[CT_ADDR_BAUD_RATE] = 34;
  const dxl_response_t r = handled(&servo, &port, DXL_INST_RESET, NULL, 0);
  assert_string_equal(port.log, "reply end store baud=1 ");
  assert_int_equal(port.stored_id, 1);
  assert_int_equal(port.stored_baud, 1);
  assert_int_equal(servo.table[CT_ADDR_RETURN_DELAY_TIME], 250);
  assert_true(dxl_after_waits_for_reply(r.after));
}

static void test_a_silent_eeprom_write_is_stored_all_the_same(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  servo.table[CT_ADDR_STATUS_RETURN_LEVEL] = 0;
  handled(&servo, &port, DXL_INST_WRITE, (const uint8_t[]){CT_ADDR_ALARM_LED, 5}, 2);
  assert_string_equal(port.log, "store ");
}

static void test_ram_writes_reads_and_errors_leave_the_eeprom_and_the_baud_alone(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  handled(&servo, &port, DXL_INST_WRITE, (const uint8_t[]){CT_ADDR_LED, 1}, 2);
  handled(&servo, &port, DXL_INST_READ, (const uint8_t[]){CT_ADDR_ID, 1}, 2);
  handled(&servo, &port, DXL_INST_WRITE, (const uint8_t[]){CT_ADDR_ID, 254}, 2); /* Range Error */
  handled(&servo, &port, DXL_INST_PING, NULL, 0);
  assert_string_equal(port.log, "reply end reply end reply end reply end ");
}

static void test_an_action_that_runs_a_registered_eeprom_write_stores_it_as_a_write_does(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  handled(&servo, &port, DXL_INST_REG_WRITE, (const uint8_t[]){CT_ADDR_RETURN_DELAY_TIME, 0}, 2);
  handled(&servo, &port, DXL_INST_ACTION, NULL, 0);
  assert_string_equal(port.log, "reply end reply store end ");
}

static const uint8_t boot_key[4] = {'B', 'O', 'O', 'T'};

#if DXL_HAS_BOOTLOADER
/* docs/bootloader.md "Entering from the application": answered like a PING, at every Status
 * Return Level, then the bootloader, after the reply's end. */
static void test_the_bootloader_instruction_is_answered_then_enters_the_bootloader(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  servo.table[CT_ADDR_STATUS_RETURN_LEVEL] = 0;
  const dxl_response_t r = handled(&servo, &port, DXL_INST_BOOTLOADER, boot_key, 4);
  assert_string_equal(port.log, "reply end bootloader ");
  assert_int_equal(r.length, 6);
  assert_int_equal(r.bytes[4], 0);
  assert_true(dxl_after_waits_for_reply(r.after));
}

/* A pending store of the settings is started before the bootloader is asked for (the port
 * enters it only once no store is under way: firmware/app/link_port.c). */
static void test_a_store_under_way_comes_before_the_bootloader(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  handled(&servo, &port, DXL_INST_WRITE, (const uint8_t[]){CT_ADDR_ID, 9}, 2);
  const dxl_packet_t packet = {9, DXL_INST_BOOTLOADER, 4, boot_key, 0};
  dxl_response_t response;
  dxl_servo_prepare(&servo, &packet, &response);
  dxl_servo_commit(&servo, &response);
  dxl_after_commit(&servo, response.after, &port);
  dxl_after_reply(&servo, response.after, &port);
  assert_string_equal(port.log, "reply store end bootloader ");
}
#endif

/* Without the key, to broadcast, or in a build without a bootloader: an unknown instruction. */
static void test_the_bootloader_instruction_needs_its_key_and_an_id(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  const uint8_t wrong_key[4] = {'B', 'O', 'O', 'X'};
  dxl_response_t r = handled(&servo, &port, DXL_INST_BOOTLOADER, wrong_key, 4);
  assert_int_equal(r.bytes[4], DXL_ERR_INSTRUCTION);
  r = handled(&servo, &port, DXL_INST_BOOTLOADER, boot_key, 3);
  assert_int_equal(r.bytes[4], DXL_ERR_INSTRUCTION);
  r = handled(&servo, &port, DXL_INST_BOOTLOADER, NULL, 0);
  assert_int_equal(r.bytes[4], DXL_ERR_INSTRUCTION);
  const dxl_packet_t broadcast = {DXL_ID_BROADCAST, DXL_INST_BOOTLOADER, 4, boot_key, 0};
  dxl_servo_prepare(&servo, &broadcast, &r);
  assert_int_equal(r.length, 0);
  assert_int_equal(r.after, 0);
  r = handled(&servo, &port, DXL_INST_BOOTLOADER, boot_key, 4);
  assert_int_equal(r.bytes[4], DXL_HAS_BOOTLOADER ? 0 : DXL_ERR_INSTRUCTION);
  assert_string_equal(port.log, DXL_HAS_BOOTLOADER ? "reply end reply end reply end reply end bootloader "
                                                   : "reply end reply end reply end reply end ");
}

int main(void) {
  const struct CMUnitTest tests[] = {
#if DXL_HAS_BOOTLOADER
      cmocka_unit_test(test_the_bootloader_instruction_is_answered_then_enters_the_bootloader),
      cmocka_unit_test(test_a_store_under_way_comes_before_the_bootloader),
#endif
      cmocka_unit_test(test_the_bootloader_instruction_needs_its_key_and_an_id),
      cmocka_unit_test(test_a_write_of_the_eeprom_area_is_answered_then_stored_while_the_reply_goes_out),
      cmocka_unit_test(test_a_new_id_is_stored_and_the_reply_still_carries_the_old_one),
      cmocka_unit_test(test_a_new_baud_is_stored_at_once_and_applied_after_the_reply),
      cmocka_unit_test(test_reset_answers_first_then_stores_the_factory_defaults_and_their_baud),
      cmocka_unit_test(test_a_silent_eeprom_write_is_stored_all_the_same),
      cmocka_unit_test(test_ram_writes_reads_and_errors_leave_the_eeprom_and_the_baud_alone),
      cmocka_unit_test(test_an_action_that_runs_a_registered_eeprom_write_stores_it_as_a_write_does),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
