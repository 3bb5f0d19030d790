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
  dxl_response_t ready;
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

/* The stream contract (dxl_servo.h "Streamed replies"): a packet the RX interrupt may start
 * answering (its ID, an instruction in dxl_servo_stream_mask(), a WRITE's start address past
 * the ID and the Baud Rate) gets a prepared reply that is non-empty, has nothing to do after it
 * but a store and starts FF FF ID. Every level, Lock off and on, REG_WRITE slot empty and full, every
 * parameter count with start addresses 0 and DXL_STREAM_WRITE_MIN_ADDR, and every start address at short counts. */
static void expect_streamable(const dxl_servo_t *servo, uint8_t instruction, uint8_t count, const uint8_t *params) {
  static dxl_response_t response;
  const dxl_packet_t packet = {OWN_ID, instruction, count, params, 0};
  if (instruction == DXL_INST_WRITE && count != 0 && params[0] < DXL_STREAM_WRITE_MIN_ADDR) {
    return; /* not streamed */
  }
  dxl_servo_prepare(servo, &packet, &response);
  if (response.length < DXL_PING_REPLY_BYTES || (response.after & (DXL_AFTER_FACTORY_RESET | DXL_AFTER_APPLY_BAUD)) != 0 || response.bytes[0] != DXL_HEADER_BYTE ||
      response.bytes[1] != DXL_HEADER_BYTE || response.bytes[2] != OWN_ID) {
    fail_msg("instruction 0x%02X, %u params from address %u: length %u, after 0x%02X", instruction, count, params[0],
             response.length, response.after);
  }
}

static void test_a_streamed_packet_is_answered_at_once_with_the_header_it_streams(void **state) {
  (void)state;
  uint8_t params[DXL_PACKET_MAX_BYTES];
  static const uint8_t short_counts[] = {0, 1, 2, 3, 4, 5, 12, 50};
  unsigned streamed_instructions = 0;
  for (uint8_t level = 0; level < LEVELS; level++) {
    for (uint8_t variant = 0; variant < 4u; variant++) {
      dxl_servo_t servo;
      given_servo(&servo, level);
      servo.table[CT_ADDR_LOCK] = (uint8_t)(variant & 1u);
      if (variant & 2u) { /* a registered write waiting */
        servo.reg_start = CT_ADDR_LED;
        servo.reg_len = 1;
        servo.reg_data[0] = 1;
        servo.table[CT_ADDR_REGISTERED_INSTRUCTION] = 1;
      }
      const uint8_t mask = dxl_servo_stream_mask(&servo);
      for (unsigned instruction = 0; instruction < 8u; instruction++) {
        if (!(mask & (1u << instruction))) {
          continue;
        }
        streamed_instructions++;
        assert_true(instruction >= DXL_INST_PING && instruction <= DXL_INST_ACTION);
        for (unsigned fill = 0; fill < 2u; fill++) {
          memset(params, fill ? 0xFF : 0x01, sizeof params);
          for (unsigned count = 0; count <= 253u; count++) {
            params[0] = 0;
            expect_streamable(&servo, (uint8_t)instruction, (uint8_t)count, params);
            params[0] = DXL_STREAM_WRITE_MIN_ADDR;
            expect_streamable(&servo, (uint8_t)instruction, (uint8_t)count, params);
          }
          for (size_t c = 0; c < sizeof short_counts; c++) {
            for (unsigned start = 0; start < 256u; start++) {
              params[0] = (uint8_t)start;
              expect_streamable(&servo, (uint8_t)instruction, short_counts[c], params);
            }
          }
        }
      }
    }
  }
  /* PING at every level; READ at 1 and 2; WRITE, REG_WRITE and ACTION at 2: 1+2+5 per
   * variant. */
  assert_int_equal(streamed_instructions, 4u * (1u + 2u + 5u));
}

/* An ACTION whose registered write changes the Baud Rate applies it after its reply
 * (docs/policy.md "Replies"), which the main loop does: not streamed. The same ACTION with
 * an EEPROM write elsewhere (stored in the background) or a RAM write registered is. */
static void test_an_action_that_writes_the_baud_rate_is_not_streamed(void **state) {
  (void)state;
  dxl_servo_t servo;
  given_servo(&servo, 2);
  servo.table[CT_ADDR_REGISTERED_INSTRUCTION] = 1;
  servo.reg_start = CT_ADDR_BAUD_RATE;
  servo.reg_len = 2;
  servo.reg_data[0] = 1;
  servo.reg_data[1] = 0;
  assert_int_equal(dxl_servo_stream_mask(&servo) & (1u << DXL_INST_ACTION), 0);
  servo.reg_start = CT_ADDR_RETURN_DELAY_TIME;
  servo.reg_len = 1;
  assert_int_not_equal(dxl_servo_stream_mask(&servo) & (1u << DXL_INST_ACTION), 0);
  servo.reg_start = CT_ADDR_LED;
  assert_int_not_equal(dxl_servo_stream_mask(&servo) & (1u << DXL_INST_ACTION), 0);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_the_early_answer_decision_agrees_with_prepare_for_every_packet),
      cmocka_unit_test(test_the_ready_ping_reply_is_the_prepared_one_in_every_condition),
      cmocka_unit_test(test_a_streamed_packet_is_answered_at_once_with_the_header_it_streams),
      cmocka_unit_test(test_an_action_that_writes_the_baud_rate_is_not_streamed),
  };
  return cmocka_run_group_tests_name("fast reply path (" AX12_PROFILE_NAME ")", tests, NULL, NULL);
}
