/* The core functions behind the firmware's fast reply path (dxl_servo.h): the early "will it
 * be answered" decision and the ready PING reply agree with dxl_servo_prepare() everywhere. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "dxl_protocol.h"
#include "dxl_servo.h"

#define OWN_ID 7u
#define OTHER_ID 8u
#define LEVELS 3u

static void given_servo(dxl_servo_t *servo, uint8_t status_return_level) {
  dxl_servo_power_up(servo, NULL, 512);
  servo->table[CT_ADDR_ID] = OWN_ID;
  servo->table[CT_ADDR_STATUS_RETURN_LEVEL] = status_return_level;
}

/* Every instruction code x every parameter count x own / other / broadcast ID x Status Return
 * Level 0..2, with two parameter patterns (zeros, and a valid LED window with this servo's
 * slice for SYNC_WRITE): answered exactly when dxl_servo_answers() says so. */
static void test_the_early_answer_decision_agrees_with_prepare_for_every_packet(void **state) {
  (void)state;
  static const uint8_t ids[] = {OWN_ID, OTHER_ID, DXL_ID_BROADCAST};
  uint8_t params[2][DXL_PACKET_MAX_BYTES];
  memset(params[0], 0, sizeof params[0]);
  memset(params[1], 0, sizeof params[1]);
  params[1][0] = CT_ADDR_LED;
  params[1][1] = 1;
  params[1][2] = OWN_ID;
  params[1][3] = 1;
  static dxl_response_t response;
  for (uint8_t level = 0; level < LEVELS; level++) {
    dxl_servo_t servo;
    given_servo(&servo, level);
    for (size_t a = 0; a < sizeof ids; a++) {
      for (unsigned instruction = 0; instruction < 256u; instruction++) {
        const bool answers = dxl_servo_answers(&servo, ids[a], (uint8_t)instruction);
        for (unsigned count = 0; count <= 253u; count++) {
          for (unsigned pattern = 0; pattern < 2u; pattern++) {
            const dxl_packet_t packet = {ids[a], (uint8_t)instruction, (uint8_t)count, params[pattern], 0};
            dxl_servo_prepare(&servo, &packet, &response);
            if ((response.length != 0) != answers) {
              fail_msg("level %u, ID %u, instruction 0x%02X, %u params: prepare %s, dxl_servo_answers %s", level,
                       ids[a], instruction, count, response.length ? "answers" : "is silent",
                       answers ? "true" : "false");
            }
          }
        }
      }
    }
  }
}

static void expect_ping_reply_as_prepared(const dxl_servo_t *servo) {
  dxl_response_t response;
  const dxl_packet_t ping = {servo->table[CT_ADDR_ID], DXL_INST_PING, 0, NULL, 0};
  dxl_servo_prepare(servo, &ping, &response);
  dxl_ping_reply_t ready;
  dxl_servo_ping_reply(servo, &ready);
  assert_int_equal(response.length, DXL_PING_REPLY_BYTES);
  assert_memory_equal(ready.bytes, response.bytes, DXL_PING_REPLY_BYTES);
  assert_int_equal(ready.delay_us, response.delay_us);
}

static void test_the_ready_ping_reply_is_the_prepared_one_in_every_condition(void **state) {
  (void)state;
  dxl_servo_t servo;
  for (uint8_t level = 0; level < LEVELS; level++) {
    given_servo(&servo, level);
    expect_ping_reply_as_prepared(&servo);
    servo.table[CT_ADDR_RETURN_DELAY_TIME] = 254;
    expect_ping_reply_as_prepared(&servo);
    servo.held_conditions = DXL_ERR_VOLTAGE | DXL_ERR_OVERHEATING | DXL_ERR_OVERLOAD;
    expect_ping_reply_as_prepared(&servo);
    ct_set_u16(servo.table, CT_ADDR_GOAL_POSITION, 1023);
    ct_set_u16(servo.table, CT_ADDR_CCW_ANGLE_LIMIT, 600); /* goal outside: Angle Limit */
    expect_ping_reply_as_prepared(&servo);
    ct_set_u16(servo.table, CT_ADDR_CW_ANGLE_LIMIT, 0);
    ct_set_u16(servo.table, CT_ADDR_CCW_ANGLE_LIMIT, 0); /* wheel mode */
    servo.goal_written_in_wheel_mode = true;
    expect_ping_reply_as_prepared(&servo);
    servo.table[CT_ADDR_ID] = 0;
    expect_ping_reply_as_prepared(&servo);
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_the_early_answer_decision_agrees_with_prepare_for_every_packet),
      cmocka_unit_test(test_the_ready_ping_reply_is_the_prepared_one_in_every_condition),
  };
  return cmocka_run_group_tests_name("fast reply path (" AX12_PROFILE_NAME ")", tests, NULL, NULL);
}
