/* The link layer (firmware/link/dxl_link.h) on the host, on a fake UART (test/support/fake_uart.h):
 * every reply path, the Return Delay Time each reply is due at, one reply at a time, what
 * follows a reply and in which order (a store at the commit, RESET's defaults and a new baud
 * after the reply has left), garbage and other servos' packets between ours, and the armed
 * path of the RX interrupt's sniff with the fake playing the interrupt. Built once per
 * behaviour profile. Bytes arrive 10 us apart (1 Mbps). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "dxl_link.h"
#include "dxl_link_port.h"
#include "dxl_protocol.h"
#include "dxl_servo.h"
#include "dxl_table.h"
#include "fake_uart.h"
#include "packet_encode.h"

#define BYTE_US 10u
#define FACTORY_ID 1u
#define FACTORY_RDT_US 500u /* Return Delay Time 250 x 2 us */

typedef struct {
  dxl_servo_t servo;
  dxl_link_t link;
  fake_uart_t uart;
} rig_t;

static rig_t rig;

static void rig_up(bool sniff) {
  memset(&rig, 0, sizeof rig);
  dxl_servo_power_up(&rig.servo, NULL, 512); /* factory defaults */
  fake_uart_init(&rig.uart, rig.servo.table[CT_ADDR_BAUD_RATE]);
  rig.uart.sniff_enabled = sniff;
  rig.uart.now_us = 1000000u;
  dxl_link_init(&rig.link, &rig.servo, &rig.uart);
}

/* Main-loop passes until the link has no more work. */
static void run(void) {
  do {
    rig.uart.woken = false;
    dxl_link_service_reply(&rig.link, &rig.servo);
    dxl_link_service_rx(&rig.link, &rig.servo);
  } while (rig.uart.woken);
}

static void arrive(const uint8_t *bytes, size_t count) {
  for (size_t i = 0; i < count; i++) {
    rig.uart.now_us += BYTE_US;
    assert_true(fake_uart_receive(&rig.uart, bytes[i]));
    run();
  }
}

/* The master sends a packet; returns its length. */
static size_t send(uint8_t id, uint8_t instruction, const uint8_t *params, size_t count) {
  uint8_t packet[DXL_PACKET_MAX_BYTES];
  const size_t length = packet_encode(packet, id, instruction, params, count);
  arrive(packet, length);
  return length;
}

/* The reply on the wire has left. */
static void sent(void) {
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_SENDING);
  rig.uart.now_us += (uint64_t)rig.uart.reply_length * BYTE_US;
  fake_uart_reply_sent(&rig.uart);
  run();
}

static void assert_reply(uint8_t error, const uint8_t *params, size_t count) {
  uint8_t expected[DXL_REPLY_MAX_BYTES];
  const size_t length = packet_encode(expected, rig.servo.table[CT_ADDR_ID], error, params, count);
  assert_int_equal(rig.uart.reply_length, length);
  assert_memory_equal(rig.uart.reply_bytes, expected, length);
}

static void assert_log(const char *expected) {
  assert_false(rig.uart.log_full);
  assert_string_equal(rig.uart.log, expected);
}

static void clear_log(void) { rig.uart.log[0] = '\0'; }

static void write_byte(uint8_t addr, uint8_t value) {
  const uint8_t params[] = {addr, value};
  send(FACTORY_ID, DXL_INST_WRITE, params, sizeof params);
  if (rig.uart.reply_state == DXL_LINK_REPLY_SENDING) {
    sent();
  }
  clear_log();
}

static void test_a_ping_is_answered_at_the_return_delay_time(void **state) {
  (void)state;
  rig_up(false);
  send(FACTORY_ID, DXL_INST_PING, NULL, 0);
  assert_log("reply+500 ");
  assert_int_equal(rig.uart.reply_start_us - rig.uart.newest_rx_us, FACTORY_RDT_US);
  assert_reply(0, NULL, 0);
  sent();
  assert_log("reply+500 sent ");
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_IDLE);
}

static void test_every_return_delay_time_is_the_delay_of_the_reply(void **state) {
  (void)state;
  rig_up(false);
  static const uint8_t delays[] = {0, 1, 2, 3, 6, 7, 100, 254};
  for (size_t i = 0; i < sizeof delays; i++) {
    write_byte(CT_ADDR_RETURN_DELAY_TIME, delays[i]);
    send(FACTORY_ID, DXL_INST_PING, NULL, 0);
    assert_int_equal(rig.uart.reply_start_us - rig.uart.newest_rx_us, 2u * delays[i]);
    assert_int_equal(rig.uart.reply_delay_us, 2u * delays[i]);
    sent();
  }
}

static void test_a_read_is_answered_with_the_items(void **state) {
  (void)state;
  rig_up(false);
  const uint8_t params[] = {CT_ADDR_ID, 3};
  send(FACTORY_ID, DXL_INST_READ, params, sizeof params);
  const uint8_t items[] = {FACTORY_ID, rig.servo.table[CT_ADDR_BAUD_RATE], 250};
  assert_reply(0, items, sizeof items);
  sent();
  assert_log("reply+500 sent ");
}

static void test_a_ram_write_is_answered_and_applied_without_a_store(void **state) {
  (void)state;
  rig_up(false);
  const uint8_t params[] = {CT_ADDR_LED, 1};
  send(FACTORY_ID, DXL_INST_WRITE, params, sizeof params);
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 1);
  assert_reply(0, NULL, 0);
  sent();
  assert_log("reply+500 sent ");
  assert_int_equal(rig.uart.store_count, 0);
}

static void test_an_eeprom_write_is_stored_at_its_commit_before_its_reply_has_left(void **state) {
  (void)state;
  rig_up(false);
  const uint8_t params[] = {CT_ADDR_CW_ANGLE_LIMIT, 0x10, 0x00};
  send(FACTORY_ID, DXL_INST_WRITE, params, sizeof params);
  assert_log("reply+500 store ");
  assert_int_equal(rig.uart.stored[CT_ADDR_CW_ANGLE_LIMIT], 0x10);
  sent();
  assert_log("reply+500 store sent ");
}

static void test_a_registered_write_waits_for_action(void **state) {
  (void)state;
  rig_up(false);
  const uint8_t params[] = {CT_ADDR_LED, 1};
  send(FACTORY_ID, DXL_INST_REG_WRITE, params, sizeof params);
  assert_reply(0, NULL, 0);
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 0);
  sent();
  send(DXL_ID_BROADCAST, DXL_INST_ACTION, NULL, 0);
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 1);
  assert_log("reply+500 sent "); /* a broadcast ACTION: no reply */
}

static void test_reset_stores_the_defaults_after_its_reply_with_the_old_id(void **state) {
  (void)state;
  rig_up(false);
  write_byte(CT_ADDR_ID, 7);
  write_byte(CT_ADDR_LED, 1);
  clear_log();
  send(7, DXL_INST_RESET, NULL, 0);
  assert_log("reply+500 ");
  assert_int_equal(rig.uart.reply_bytes[DXL_STATUS_ERROR_OFFSET - 2u], 7); /* the old ID */
  assert_int_equal(rig.servo.table[CT_ADDR_ID], 7);
  sent();
  assert_log("reply+500 sent store baud=1 "); /* the defaults' baud */
  assert_int_equal(rig.servo.table[CT_ADDR_ID], FACTORY_ID);
  assert_int_equal(rig.uart.stored[CT_ADDR_ID], FACTORY_ID);
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 0);
}

static void test_a_new_baud_applies_after_the_reply(void **state) {
  (void)state;
  rig_up(false);
  const uint8_t params[] = {CT_ADDR_BAUD_RATE, 34};
  send(FACTORY_ID, DXL_INST_WRITE, params, sizeof params);
  assert_log("reply+500 store ");
  assert_int_equal(rig.uart.baud_register, 1);
  sent();
  assert_log("reply+500 store sent baud=34 ");
}

static void test_a_sync_write_is_applied_without_a_reply(void **state) {
  (void)state;
  rig_up(false);
  const uint8_t params[] = {CT_ADDR_GOAL_POSITION, 2, 2, 0x00, 0x02, FACTORY_ID, 0x10, 0x01};
  send(DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE, params, sizeof params);
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_IDLE);
  assert_log("");
  assert_int_equal(rig.servo.table[CT_ADDR_GOAL_POSITION], 0x10);
  assert_int_equal(rig.servo.table[CT_ADDR_GOAL_POSITION + 1], 0x01);
}

static void test_a_broadcast_write_is_applied_without_a_reply(void **state) {
  (void)state;
  rig_up(false);
  const uint8_t params[] = {CT_ADDR_LED, 1};
  send(DXL_ID_BROADCAST, DXL_INST_WRITE, params, sizeof params);
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_IDLE);
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 1);
}

static void test_each_status_return_level_answers_what_it_says(void **state) {
  (void)state;
  /* level: answers PING, READ, WRITE */
  static const bool answers[3][3] = {{true, false, false}, {true, true, false}, {true, true, true}};
  for (uint8_t level = 0; level < 3; level++) {
    rig_up(false);
    write_byte(CT_ADDR_STATUS_RETURN_LEVEL, level);
    const uint8_t read[] = {CT_ADDR_LED, 1};
    const uint8_t write[] = {CT_ADDR_LED, 1};
    const struct {
      uint8_t instruction;
      const uint8_t *params;
      size_t count;
    } packets[] = {{DXL_INST_PING, NULL, 0}, {DXL_INST_READ, read, 2}, {DXL_INST_WRITE, write, 2}};
    for (size_t i = 0; i < 3; i++) {
      send(FACTORY_ID, packets[i].instruction, packets[i].params, packets[i].count);
      const bool replied = rig.uart.reply_state == DXL_LINK_REPLY_SENDING;
      assert_int_equal(replied, answers[level][i]);
      if (replied) {
        sent();
      }
    }
    assert_int_equal(rig.servo.table[CT_ADDR_LED], 1); /* the silent WRITE still applied */
  }
}

static void test_a_bad_checksum_gets_a_checksum_error(void **state) {
  (void)state;
  rig_up(false);
  uint8_t packet[16];
  const size_t length = packet_encode(packet, FACTORY_ID, DXL_INST_PING, NULL, 0);
  packet[length - 1] ^= 0x01u;
  arrive(packet, length);
  assert_reply(DXL_ERR_CHECKSUM, NULL, 0);
  sent();
}

static void test_garbage_and_other_servos_packets_between_ours_are_passed_over(void **state) {
  (void)state;
  rig_up(false);
  static const uint8_t garbage[] = {0x00, 0xFF, 0x13, 0xFF, 0xFF, 0xFF, 0x02};
  arrive(garbage, sizeof garbage);
  const uint8_t read[] = {CT_ADDR_PRESENT_POSITION, 2};
  send(2, DXL_INST_READ, read, sizeof read);   /* another servo's request */
  const uint8_t status[] = {0x00, 0x02};
  send(2, 0x00, status, sizeof status);        /* and its status packet */
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_IDLE);
  rig.uart.now_us += 150000u; /* a gap ends whatever the garbage started */
  dxl_link_tick(&rig.link, &rig.servo, dxl_link_port_now_ms(&rig.uart));
  run();
  clear_log();
  send(FACTORY_ID, DXL_INST_PING, NULL, 0);
  assert_log("reply+500 ");
  assert_reply(0, NULL, 0);
  sent();
  assert_int_equal(rig.link.finder.fill, 0);
}

static void test_packets_that_come_during_a_reply_wait_for_its_end(void **state) {
  (void)state;
  rig_up(false);
  write_byte(CT_ADDR_RETURN_DELAY_TIME, 0);
  send(FACTORY_ID, DXL_INST_PING, NULL, 0);
  const uint8_t params[] = {CT_ADDR_LED, 1};
  send(FACTORY_ID, DXL_INST_WRITE, params, sizeof params);
  assert_log("reply+0 ");
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 0); /* still in the ring */
  sent();
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 1);
  assert_log("reply+0 sent reply+0 "); /* its moment has passed: at once */
  sent();
}

/* The armed path: the fake plays the RX interrupt's sniff. A packet to this servo arrives up
 * to its checksum, the sniff arming at the last byte but one; returns the checksum. */
static uint8_t arrive_up_to_checksum(uint8_t instruction, const uint8_t *params, size_t count) {
  uint8_t packet[DXL_PACKET_MAX_BYTES];
  const size_t length = packet_encode(packet, FACTORY_ID, instruction, params, count);
  assert_int_equal(rig.uart.sniff, DXL_LINK_SNIFF_WAITING);
  for (size_t i = 0; i + 1 < length; i++) {
    rig.uart.now_us += BYTE_US;
    fake_uart_receive(&rig.uart, packet[i]);
    if (i + 2 == length) {
      fake_uart_arm(&rig.uart, instruction == DXL_INST_PING && count == 0);
      assert_int_equal(fake_uart_reply_ready(&rig.uart), count == 0 && instruction == DXL_INST_PING
                                                             ? DXL_PING_REPLY_BYTES
                                                             : DXL_STREAM_HEADER_BYTES);
    }
    run();
  }
  return packet[length - 1];
}

static void arrive_armed(uint8_t instruction, const uint8_t *params, size_t count, bool checksum_good) {
  const uint8_t checksum = arrive_up_to_checksum(instruction, params, count);
  rig.uart.now_us += BYTE_US;
  fake_uart_checksum(&rig.uart, checksum_good ? checksum : (uint8_t)(checksum ^ 1u), checksum_good);
  run();
}

static void test_an_armed_ping_is_answered_by_the_uart_with_the_ready_reply(void **state) {
  (void)state;
  rig_up(true);
  const uint8_t *ready = rig.uart.reply_bytes;
  uint8_t expected[8];
  memcpy(expected, ready, DXL_PING_REPLY_BYTES);
  arrive_armed(DXL_INST_PING, NULL, 0, true);
  assert_log("armed start ");
  assert_int_equal(rig.uart.reply_length, DXL_PING_REPLY_BYTES);
  assert_memory_equal(rig.uart.reply_bytes, expected, DXL_PING_REPLY_BYTES);
  assert_reply(0, NULL, 0);
  sent();
  assert_int_equal(rig.uart.sniff, DXL_LINK_SNIFF_WAITING); /* listening again */
}

static void test_an_armed_read_is_published_before_its_checksum_and_committed_after(void **state) {
  (void)state;
  rig_up(true);
  const uint8_t params[] = {CT_ADDR_ID, 2};
  const uint8_t checksum = arrive_up_to_checksum(DXL_INST_READ, params, sizeof params);
  /* The checksum is still on the wire: the whole reply is published already. */
  const uint8_t items[] = {FACTORY_ID, rig.servo.table[CT_ADDR_BAUD_RATE]};
  assert_reply(0, items, sizeof items);
  assert_int_equal(fake_uart_reply_ready(&rig.uart), rig.uart.reply_length);
  rig.uart.now_us += BYTE_US;
  fake_uart_checksum(&rig.uart, checksum, true);
  run();
  assert_log("armed start ");
  sent();
}

static void test_an_armed_eeprom_write_is_stored_after_its_checksum(void **state) {
  (void)state;
  rig_up(true);
  const uint8_t params[] = {CT_ADDR_CW_ANGLE_LIMIT, 0x20, 0x00};
  const uint8_t checksum = arrive_up_to_checksum(DXL_INST_WRITE, params, sizeof params);
  assert_int_equal(rig.servo.table[CT_ADDR_CW_ANGLE_LIMIT], 0); /* prepared, not committed */
  assert_int_equal(rig.uart.store_count, 0);
  rig.uart.now_us += BYTE_US;
  fake_uart_checksum(&rig.uart, checksum, true);
  run();
  assert_log("armed start store ");
  assert_int_equal(rig.servo.table[CT_ADDR_CW_ANGLE_LIMIT], 0x20);
  sent();
}

static void test_an_armed_packet_with_a_bad_checksum_is_answered_from_the_finder(void **state) {
  (void)state;
  rig_up(true);
  const uint8_t params[] = {CT_ADDR_LED, 1};
  arrive_armed(DXL_INST_WRITE, params, sizeof params, false);
  assert_log("armed reply+500 ");
  assert_reply(DXL_ERR_CHECKSUM, NULL, 0);
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 0);
  sent();
}

static void test_an_armed_packet_whose_checksum_never_comes_is_given_up(void **state) {
  (void)state;
  rig_up(true);
  const uint8_t params[] = {CT_ADDR_LED, 1};
  (void)arrive_up_to_checksum(DXL_INST_WRITE, params, sizeof params);
  for (unsigned ms = 0; ms < DXL_LINK_SNIFF_MAX_MS + 1u; ms++) {
    rig.uart.now_us += 1000u;
    dxl_link_tick(&rig.link, &rig.servo, dxl_link_port_now_ms(&rig.uart));
    run();
  }
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_IDLE); /* disarmed */
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 0);
  rig.uart.now_us += 150000u; /* the gap ends the partial packet */
  dxl_link_tick(&rig.link, &rig.servo, dxl_link_port_now_ms(&rig.uart));
  run();
  assert_int_equal(rig.link.finder.fill, 0);
  assert_int_equal(rig.uart.sniff, DXL_LINK_SNIFF_WAITING);
  arrive_armed(DXL_INST_PING, NULL, 0, true); /* and the next packet is armed again */
  assert_reply(0, NULL, 0);
  sent();
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_a_ping_is_answered_at_the_return_delay_time),
      cmocka_unit_test(test_every_return_delay_time_is_the_delay_of_the_reply),
      cmocka_unit_test(test_a_read_is_answered_with_the_items),
      cmocka_unit_test(test_a_ram_write_is_answered_and_applied_without_a_store),
      cmocka_unit_test(test_an_eeprom_write_is_stored_at_its_commit_before_its_reply_has_left),
      cmocka_unit_test(test_a_registered_write_waits_for_action),
      cmocka_unit_test(test_reset_stores_the_defaults_after_its_reply_with_the_old_id),
      cmocka_unit_test(test_a_new_baud_applies_after_the_reply),
      cmocka_unit_test(test_a_sync_write_is_applied_without_a_reply),
      cmocka_unit_test(test_a_broadcast_write_is_applied_without_a_reply),
      cmocka_unit_test(test_each_status_return_level_answers_what_it_says),
      cmocka_unit_test(test_a_bad_checksum_gets_a_checksum_error),
      cmocka_unit_test(test_garbage_and_other_servos_packets_between_ours_are_passed_over),
      cmocka_unit_test(test_packets_that_come_during_a_reply_wait_for_its_end),
      cmocka_unit_test(test_an_armed_ping_is_answered_by_the_uart_with_the_ready_reply),
      cmocka_unit_test(test_an_armed_read_is_published_before_its_checksum_and_committed_after),
      cmocka_unit_test(test_an_armed_eeprom_write_is_stored_after_its_checksum),
      cmocka_unit_test(test_an_armed_packet_with_a_bad_checksum_is_answered_from_the_finder),
      cmocka_unit_test(test_an_armed_packet_whose_checksum_never_comes_is_given_up),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
