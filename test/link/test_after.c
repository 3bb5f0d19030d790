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

int main(void) {
  const struct CMUnitTest tests[] = {
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
