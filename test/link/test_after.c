/* What follows a handled packet, in order (firmware/link/dxl_after.h), on the host with a
 * recording port: the EEPROM area is stored before a write's reply, RESET's defaults are
 * stored after its reply, a new baud applies after the reply, and nothing else happens. Each
 * packet goes through the core (dxl_servo_handle) as the firmware's main loop and the host bus
 * hand it on. */
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

bool dxl_after_port_storing(void *port) {
  (void)port;
  return false;
}

void dxl_after_port_set_baud(void *port, uint8_t baud_register) {
  char text[16];
  snprintf(text, sizeof text, "baud=%u ", baud_register);
  log_event(port, text);
}

/* A packet to servo 1 handled as the main loop does: before the reply, the reply (when there
 * is one), after it. Returns the response. */
static dxl_response_t handled(dxl_servo_t *servo, port_t *port, uint8_t instruction, const uint8_t *params,
                              uint8_t count) {
  const dxl_packet_t packet = {1, instruction, count, params, 0};
  dxl_response_t response;
  dxl_servo_handle(servo, &packet, &response);
  (void)dxl_after_before_reply(servo, response.after, port);
  if (response.length != 0) {
    log_event(port, "reply ");
  }
  dxl_after_reply(servo, response.after, port);
  return response;
}

static void given_servo(dxl_servo_t *servo, port_t *port) {
  memset(port, 0, sizeof *port);
  dxl_servo_power_up(servo, NULL, 512);
}

static void test_a_write_of_the_eeprom_area_is_stored_before_its_reply(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  handled(&servo, &port, DXL_INST_WRITE, (const uint8_t[]){CT_ADDR_RETURN_DELAY_TIME, 10}, 2);
  assert_string_equal(port.log, "store reply ");
}

static void test_a_new_id_is_stored_before_the_reply_that_still_carries_the_old_one(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  const dxl_response_t r = handled(&servo, &port, DXL_INST_WRITE, (const uint8_t[]){CT_ADDR_ID, 7}, 2);
  assert_string_equal(port.log, "store reply ");
  assert_int_equal(port.stored_id, 7);
  assert_int_equal(r.bytes[2], 1); /* FF FF ID: the old one */
}

static void test_a_new_baud_is_stored_before_the_reply_and_applied_after_it(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  handled(&servo, &port, DXL_INST_WRITE, (const uint8_t[]){CT_ADDR_BAUD_RATE, 34}, 2);
  assert_string_equal(port.log, "store reply baud=34 ");
  assert_int_equal(port.stored_baud, 34);
}

static void test_reset_answers_first_then_stores_the_factory_defaults_and_their_baud(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  servo.table[CT_ADDR_ID] = 1;
  servo.table[CT_ADDR_BAUD_RATE] = 34;
  handled(&servo, &port, DXL_INST_RESET, NULL, 0);
  assert_string_equal(port.log, "reply store baud=1 ");
  assert_int_equal(port.stored_id, 1);
  assert_int_equal(port.stored_baud, 1);
  assert_int_equal(servo.table[CT_ADDR_RETURN_DELAY_TIME], 250);
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
  assert_string_equal(port.log, "reply reply reply reply ");
}

static void test_an_action_that_runs_a_registered_eeprom_write_is_stored_before_its_reply(void **state) {
  (void)state;
  dxl_servo_t servo;
  port_t port;
  given_servo(&servo, &port);
  handled(&servo, &port, DXL_INST_REG_WRITE, (const uint8_t[]){CT_ADDR_RETURN_DELAY_TIME, 0}, 2);
  handled(&servo, &port, DXL_INST_ACTION, NULL, 0);
  assert_string_equal(port.log, "reply store reply ");
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_a_write_of_the_eeprom_area_is_stored_before_its_reply),
      cmocka_unit_test(test_a_new_id_is_stored_before_the_reply_that_still_carries_the_old_one),
      cmocka_unit_test(test_a_new_baud_is_stored_before_the_reply_and_applied_after_it),
      cmocka_unit_test(test_reset_answers_first_then_stores_the_factory_defaults_and_their_baud),
      cmocka_unit_test(test_a_silent_eeprom_write_is_stored_all_the_same),
      cmocka_unit_test(test_ram_writes_reads_and_errors_leave_the_eeprom_and_the_baud_alone),
      cmocka_unit_test(test_an_action_that_runs_a_registered_eeprom_write_is_stored_before_its_reply),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
