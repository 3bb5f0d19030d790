/* The link layer (firmware/link/dxl_link.h) on the host, on a fake UART (test/support/fake_uart.h,
 * whose receiver frames as the firmware's RX interrupt does): every reply path and which Status
 * Return Level answers it, a broadcast PING per profile, the Return Delay Time each reply is due
 * at, one reply at a time, what follows a reply and in which order (a store at the commit,
 * RESET's defaults and a new baud after the reply has left), garbage and other servos' packets
 * between ours, the ready PING reply's error byte, the armed path with the fake playing the
 * RX interrupt's arming, another servo's packet passed over while listening, a header, a skip
 * or an armed packet that stops ended by the 100 ms gap; no packet across a gap while a reply
 * holds up the bytes before it. Built once per behaviour profile (DXL_PROFILE). Bytes arrive
 * 10 us apart (1 Mbps). */
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
#define PACKET_OFS_ID 2u
#define PACKET_OFS_LENGTH 3u
#define PACKET_OFS_INSTRUCTION 4u
#define UNKNOWN_INSTRUCTION 0x55u /* no instruction of the AX-12 */
/* docs/policy.md "Replies": the AX-12 answers a broadcast PING, the AX-12A does not. */
#define BROADCAST_PING_ANSWERED (DXL_PROFILE == DXL_PROFILE_AX12)

typedef struct {
  dxl_servo_t servo;
  dxl_link_t link;
  fake_uart_t uart;
  unsigned handled_count; /* packets the link has handled (dxl_link_port_handled) */
  uint8_t handled_id;     /* the last one's ID and instruction */
  uint8_t handled_instruction;
} rig_t;

static rig_t rig;

static void record_handled(void *context, dxl_find_result_t found, const uint8_t *bytes, uint16_t length,
                           const dxl_response_t *response) {
  (void)found;
  (void)length;
  (void)response;
  rig_t *handled_by = context;
  handled_by->handled_count++;
  handled_by->handled_id = bytes[PACKET_OFS_ID];
  handled_by->handled_instruction = bytes[PACKET_OFS_INSTRUCTION];
}

static void rig_up(void) {
  memset(&rig, 0, sizeof rig);
  dxl_servo_power_up(&rig.servo, NULL, 512); /* factory defaults */
  fake_uart_init(&rig.uart, rig.servo.table[CT_ADDR_BAUD_RATE]);
  rig.uart.on_handled = record_handled;
  rig.uart.context = &rig;
  rig.uart.now_us = 1000000u;
  dxl_link_init(&rig.link, &rig.servo, &rig.uart);
}

/* Main-loop passes until the link has no more work. */
static void run(void) {
  bool more;
  do {
    dxl_link_service_reply(&rig.link, &rig.servo);
    more = dxl_link_service_rx(&rig.link, &rig.servo);
  } while (more);
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

/* count milliseconds of the link's clock: a tick each, then main-loop passes. */
static void tick_ms(unsigned count) {
  for (unsigned ms = 0; ms < count; ms++) {
    rig.uart.now_us += 1000u;
    dxl_link_tick(&rig.link);
    run();
  }
}

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
  rig_up();
  send(FACTORY_ID, DXL_INST_PING, NULL, 0);
  assert_log("reply+500 ");
  assert_int_equal(rig.uart.reply_start_us - rig.uart.newest_end_us, FACTORY_RDT_US);
  assert_reply(0, NULL, 0);
  sent();
  assert_log("reply+500 sent ");
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_IDLE);
}

static void test_every_return_delay_time_is_the_delay_of_the_reply(void **state) {
  (void)state;
  rig_up();
  static const uint8_t delays[] = {0, 1, 2, 3, 6, 7, 100, 254};
  for (size_t i = 0; i < sizeof delays; i++) {
    write_byte(CT_ADDR_RETURN_DELAY_TIME, delays[i]);
    send(FACTORY_ID, DXL_INST_PING, NULL, 0);
    assert_int_equal(rig.uart.reply_start_us - rig.uart.newest_end_us, 2u * delays[i]);
    assert_int_equal(rig.uart.reply_delay_us, 2u * delays[i]);
    sent();
  }
}

static void test_a_read_is_answered_with_the_items(void **state) {
  (void)state;
  rig_up();
  const uint8_t params[] = {CT_ADDR_ID, 3};
  send(FACTORY_ID, DXL_INST_READ, params, sizeof params);
  const uint8_t items[] = {FACTORY_ID, rig.servo.table[CT_ADDR_BAUD_RATE], 250};
  assert_reply(0, items, sizeof items);
  sent();
  assert_log("reply+500 sent ");
}

static void test_a_ram_write_is_answered_and_applied_without_a_store(void **state) {
  (void)state;
  rig_up();
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
  rig_up();
  const uint8_t params[] = {CT_ADDR_CW_ANGLE_LIMIT, 0x10, 0x00};
  send(FACTORY_ID, DXL_INST_WRITE, params, sizeof params);
  assert_log("reply+500 store ");
  assert_int_equal(rig.uart.stored[CT_ADDR_CW_ANGLE_LIMIT], 0x10);
  sent();
  assert_log("reply+500 store sent ");
}

static void test_a_registered_write_waits_for_action(void **state) {
  (void)state;
  rig_up();
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
  rig_up();
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
  rig_up();
  const uint8_t params[] = {CT_ADDR_BAUD_RATE, 34};
  send(FACTORY_ID, DXL_INST_WRITE, params, sizeof params);
  assert_log("reply+500 store ");
  assert_int_equal(rig.uart.baud_register, 1);
  sent();
  assert_log("reply+500 store sent baud=34 ");
}

static void test_a_sync_write_is_applied_without_a_reply(void **state) {
  (void)state;
  rig_up();
  const uint8_t params[] = {CT_ADDR_GOAL_POSITION, 2, 2, 0x00, 0x02, FACTORY_ID, 0x10, 0x01};
  send(DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE, params, sizeof params);
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_IDLE);
  assert_log("");
  assert_int_equal(rig.servo.table[CT_ADDR_GOAL_POSITION], 0x10);
  assert_int_equal(rig.servo.table[CT_ADDR_GOAL_POSITION + 1], 0x01);
}

static void test_a_broadcast_write_is_applied_without_a_reply(void **state) {
  (void)state;
  rig_up();
  const uint8_t params[] = {CT_ADDR_LED, 1};
  send(DXL_ID_BROADCAST, DXL_INST_WRITE, params, sizeof params);
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_IDLE);
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 1);
}

static void test_each_status_return_level_answers_each_instruction_as_the_policy_says(void **state) {
  (void)state;
  /* docs/policy.md "Replies": level 0 answers PING only, 1 PING and READ, 2 everything sent to
   * this servo; a SYNC_WRITE is broadcast and never answered. Answered or not, each packet
   * does its work: after it, table[addr] == value. */
  const uint8_t led_on[] = {CT_ADDR_LED, 1};
  const uint8_t goal_256[] = {CT_ADDR_GOAL_POSITION, 0x00, 0x01};
  const uint8_t sync_led_off[] = {CT_ADDR_LED, 1, FACTORY_ID, 0};
  const uint8_t never = 3; /* no level answers it */
  const struct {
    uint8_t id;
    uint8_t instruction;
    const uint8_t *params;
    size_t count;
    uint8_t lowest_level_answered;
    uint8_t error;
    uint8_t addr;
    uint8_t value;
  } packets[] = {
      {FACTORY_ID, DXL_INST_PING, NULL, 0, 0, 0, CT_ADDR_LED, 0},
      {FACTORY_ID, DXL_INST_READ, led_on, sizeof led_on, 1, 0, CT_ADDR_LED, 0},
      {FACTORY_ID, DXL_INST_WRITE, led_on, sizeof led_on, 2, 0, CT_ADDR_LED, 1},
      {FACTORY_ID, DXL_INST_REG_WRITE, goal_256, sizeof goal_256, 2, 0, CT_ADDR_REGISTERED_INSTRUCTION, 1},
      {FACTORY_ID, DXL_INST_ACTION, NULL, 0, 2, 0, CT_ADDR_GOAL_POSITION + 1, 0x01},
      {DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE, sync_led_off, sizeof sync_led_off, never, 0, CT_ADDR_LED, 0},
      {FACTORY_ID, UNKNOWN_INSTRUCTION, NULL, 0, 2, DXL_ERR_INSTRUCTION, CT_ADDR_LED, 0},
      {FACTORY_ID, DXL_INST_RESET, NULL, 0, 2, 0, CT_ADDR_STATUS_RETURN_LEVEL, 2}, /* the defaults */
  };
  for (uint8_t level = 0; level < 3; level++) {
    rig_up();
    write_byte(CT_ADDR_STATUS_RETURN_LEVEL, level);
    for (size_t i = 0; i < sizeof packets / sizeof packets[0]; i++) {
      send(packets[i].id, packets[i].instruction, packets[i].params, packets[i].count);
      assert_int_equal(rig.handled_count, i + 2u); /* write_byte's packet first */
      const bool replied = rig.uart.reply_state == DXL_LINK_REPLY_SENDING;
      assert_int_equal(replied, level >= packets[i].lowest_level_answered);
      if (replied) {
        assert_int_equal(rig.uart.reply_start_us - rig.uart.newest_end_us, FACTORY_RDT_US);
        assert_int_equal(rig.uart.reply_bytes[DXL_STATUS_ERROR_OFFSET], packets[i].error);
        sent();
      }
      assert_int_equal(rig.servo.table[packets[i].addr], packets[i].value);
    }
  }
}

static void test_a_bad_checksum_gets_a_checksum_error(void **state) {
  (void)state;
  rig_up();
  uint8_t packet[16];
  const size_t length = packet_encode(packet, FACTORY_ID, DXL_INST_PING, NULL, 0);
  packet[length - 1] ^= 0x01u;
  arrive(packet, length);
  assert_reply(DXL_ERR_CHECKSUM, NULL, 0);
  sent();
}

static void test_garbage_and_other_servos_packets_between_ours_are_passed_over(void **state) {
  (void)state;
  rig_up();
  static const uint8_t garbage[] = {0x00, 0xFF, 0x13, 0xFF, 0xFF, 0xFF, 0x02};
  arrive(garbage, sizeof garbage);
  const uint8_t read[] = {CT_ADDR_PRESENT_POSITION, 2};
  send(2, DXL_INST_READ, read, sizeof read);   /* another servo's request */
  const uint8_t status[] = {0x00, 0x02};
  send(2, 0x00, status, sizeof status);        /* and its status packet */
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_IDLE);
  rig.uart.now_us += 150000u; /* a gap ends whatever the garbage started */
  dxl_link_tick(&rig.link);
  run();
  clear_log();
  send(FACTORY_ID, DXL_INST_PING, NULL, 0);
  assert_log("reply+500 ");
  assert_reply(0, NULL, 0);
  sent();
  assert_true(dxl_finder_idle(&rig.link.finder));
}

static void test_packets_that_come_during_a_reply_wait_for_its_end(void **state) {
  (void)state;
  rig_up();
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

/* The armed path: the fake plays the RX interrupt's arming. A packet to this servo arrives up to
 * its checksum while the link listens, armed at the last byte but one; returns the checksum. */
static uint8_t arrive_up_to_checksum(uint8_t instruction, const uint8_t *params, size_t count) {
  uint8_t packet[DXL_PACKET_MAX_BYTES];
  const size_t length = packet_encode(packet, FACTORY_ID, instruction, params, count);
  assert_true(rig.uart.listening);
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
  rig_up();
  const uint8_t *ready = rig.uart.reply_bytes;
  uint8_t expected[8];
  memcpy(expected, ready, DXL_PING_REPLY_BYTES);
  arrive_armed(DXL_INST_PING, NULL, 0, true);
  assert_log("armed start ");
  assert_int_equal(rig.uart.reply_length, DXL_PING_REPLY_BYTES);
  assert_memory_equal(rig.uart.reply_bytes, expected, DXL_PING_REPLY_BYTES);
  assert_reply(0, NULL, 0);
  sent();
  assert_true(rig.uart.listening); /* listening again */
}

static void test_an_armed_read_is_published_before_its_checksum_and_committed_after(void **state) {
  (void)state;
  rig_up();
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
  rig_up();
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
  rig_up();
  const uint8_t params[] = {CT_ADDR_LED, 1};
  arrive_armed(DXL_INST_WRITE, params, sizeof params, false);
  assert_log("armed reply+500 ");
  assert_reply(DXL_ERR_CHECKSUM, NULL, 0);
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 0);
  sent();
}

/* Its reply stays armed through the gap rule's 100 ms (a checksum then still starts it), and is
 * withdrawn with the partial packet after it. */
static void test_an_armed_packet_whose_checksum_never_comes_is_given_up(void **state) {
  (void)state;
  rig_up();
  const uint8_t params[] = {CT_ADDR_LED, 1};
  (void)arrive_up_to_checksum(DXL_INST_WRITE, params, sizeof params);
  tick_ms(DXL_PACKET_GAP_TIMEOUT_MS);
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_ARMED);
  tick_ms(2);
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_IDLE); /* disarmed */
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 0);
  assert_true(dxl_finder_idle(&rig.link.finder));
  assert_true(rig.uart.listening);
  arrive_armed(DXL_INST_PING, NULL, 0, true); /* and the next packet is armed again */
  assert_reply(0, NULL, 0);
  sent();
}

static void test_the_armed_path_asks_the_delay_of_every_return_delay_time(void **state) {
  (void)state;
  rig_up();
  static const uint8_t delays[] = {0, 1, 2, 5, 6, 100, 254};
  uint8_t in_force = 250; /* the factory's */
  for (size_t i = 0; i < sizeof delays; i++) {
    const uint8_t write[] = {CT_ADDR_RETURN_DELAY_TIME, delays[i]};
    arrive_armed(DXL_INST_WRITE, write, sizeof write, true);
    assert_int_equal(rig.uart.reply_delay_us, 2u * in_force); /* answered at the old delay */
    assert_int_equal(rig.uart.reply_start_us - rig.uart.newest_end_us, 2u * in_force);
    sent();
    in_force = delays[i];
    arrive_armed(DXL_INST_PING, NULL, 0, true);
    assert_int_equal(rig.uart.reply_delay_us, 2u * in_force);
    assert_int_equal(rig.uart.reply_start_us - rig.uart.newest_end_us, 2u * in_force);
    sent();
    const uint8_t read[] = {CT_ADDR_RETURN_DELAY_TIME, 1};
    arrive_armed(DXL_INST_READ, read, sizeof read, true);
    assert_reply(0, &in_force, 1);
    assert_int_equal(rig.uart.reply_delay_us, 2u * in_force);
    assert_int_equal(rig.uart.reply_start_us - rig.uart.newest_end_us, 2u * in_force);
    sent();
  }
}

static void test_an_action_to_this_servo_is_answered_after_a_registered_write(void **state) {
  (void)state;
  const uint8_t led_on[] = {CT_ADDR_LED, 1};
  /* Not armed: answered from the main loop. */
  rig_up();
  send(FACTORY_ID, DXL_INST_REG_WRITE, led_on, sizeof led_on);
  sent();
  clear_log();
  send(FACTORY_ID, DXL_INST_ACTION, NULL, 0);
  assert_log("reply+500 ");
  assert_reply(0, NULL, 0);
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 1);
  assert_int_equal(rig.servo.table[CT_ADDR_REGISTERED_INSTRUCTION], 0);
  sent();
  /* Armed: its reply published before its checksum, the registered write applied after it. */
  rig_up();
  arrive_armed(DXL_INST_REG_WRITE, led_on, sizeof led_on, true);
  sent();
  clear_log();
  const uint8_t checksum = arrive_up_to_checksum(DXL_INST_ACTION, NULL, 0);
  assert_reply(0, NULL, 0);
  assert_int_equal(fake_uart_reply_ready(&rig.uart), rig.uart.reply_length);
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 0);
  rig.uart.now_us += BYTE_US;
  fake_uart_checksum(&rig.uart, checksum, true);
  run();
  assert_log("armed start ");
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 1);
  assert_int_equal(rig.servo.table[CT_ADDR_REGISTERED_INSTRUCTION], 0);
  sent();
}

static void test_a_broadcast_ping_is_answered_in_profile_ax12_only(void **state) {
  (void)state;
  for (int armed = 0; armed < 2; armed++) {
    rig_up();
    assert_true(rig.uart.listening); /* a broadcast packet is kept all the same */
    send(DXL_ID_BROADCAST, DXL_INST_PING, NULL, 0);
    assert_int_equal(rig.handled_count, 1);
    assert_int_equal(rig.handled_id, DXL_ID_BROADCAST);
    if (BROADCAST_PING_ANSWERED) {
      assert_log("reply+500 ");
      assert_reply(0, NULL, 0); /* with this servo's ID */
      sent();
    } else {
      assert_log("");
      assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_IDLE);
    }
    /* This servo's PING next, answered with the ready reply at the Return Delay Time. */
    clear_log();
    if (armed) {
      arrive_armed(DXL_INST_PING, NULL, 0, true);
      assert_log("armed start ");
    } else {
      send(FACTORY_ID, DXL_INST_PING, NULL, 0);
      assert_log("reply+500 ");
    }
    assert_reply(0, NULL, 0);
    assert_int_equal(rig.uart.reply_delay_us, FACTORY_RDT_US);
    sent();
  }
}

static void test_the_ready_ping_reply_is_rebuilt_when_its_error_byte_would_change(void **state) {
  (void)state;
  rig_up();
  /* The control tick's conditions, reported after every tick: unchanged, nothing is rebuilt. */
  const unsigned loads = rig.uart.reply_load_count;
  dxl_link_conditions_changed(&rig.link, &rig.servo, dxl_servo_conditions(&rig.servo));
  assert_int_equal(rig.uart.reply_load_count, loads);
  /* A held condition appears: the ready reply carries it from the next PING on. */
  rig.servo.held_conditions = DXL_ERR_OVERHEATING;
  dxl_link_conditions_changed(&rig.link, &rig.servo, dxl_servo_conditions(&rig.servo));
  assert_int_equal(rig.uart.reply_load_count, loads + 1u);
  assert_reply(DXL_ERR_OVERHEATING, NULL, 0);
  dxl_link_conditions_changed(&rig.link, &rig.servo, dxl_servo_conditions(&rig.servo));
  assert_int_equal(rig.uart.reply_load_count, loads + 1u);
  arrive_armed(DXL_INST_PING, NULL, 0, true);
  assert_reply(DXL_ERR_OVERHEATING, NULL, 0);
  sent();
  /* It clears while a reply is on the wire: the reply's bytes stay as they are, the ready
   * reply is rebuilt once it has left. */
  const uint8_t read[] = {CT_ADDR_ID, 1};
  const uint8_t id[] = {FACTORY_ID};
  arrive_armed(DXL_INST_READ, read, sizeof read, true);
  rig.servo.held_conditions = 0;
  dxl_link_conditions_changed(&rig.link, &rig.servo, dxl_servo_conditions(&rig.servo));
  assert_reply(DXL_ERR_OVERHEATING, id, sizeof id);
  sent();
  assert_reply(0, NULL, 0);
  arrive_armed(DXL_INST_PING, NULL, 0, true);
  assert_reply(0, NULL, 0);
  sent();
}

/* A condition that appears while the receiver is inside a Protocol 2.0 frame (which may last
 * many milliseconds) is in the ready reply of the PING after the frame: the receiver is no
 * nearer arming there than before a header (fuzz_core found the reply of that PING stale). */
static void test_the_ready_ping_reply_follows_the_conditions_through_a_protocol2_frame(void **state) {
  (void)state;
  rig_up();
  const uint8_t protocol2_header[] = {0xFF, 0xFF, 0xFD, 0x00, 0x02, 0x03, 0x00};
  arrive(protocol2_header, sizeof protocol2_header);
  rig.servo.held_conditions = DXL_ERR_OVERHEATING;
  tick_ms(1);
  dxl_link_conditions_changed(&rig.link, &rig.servo, dxl_servo_conditions(&rig.servo));
  const uint8_t protocol2_rest[] = {0x01, 0x12, 0x34};
  arrive(protocol2_rest, sizeof protocol2_rest);
  arrive_armed(DXL_INST_PING, NULL, 0, true);
  assert_reply(DXL_ERR_OVERHEATING, NULL, 0);
  sent();
}

/* Another servo's bytes come this far apart: the whole packet takes longer than the 100 ms
 * gap, each gap between its bytes is shorter, so it is one packet (docs/policy.md "Framing and
 * bus"). */
#define SLOW_BYTE_MS 30u

/* The first arriving bytes of another servo's packet while the link listens: its header framed,
 * its LENGTH starting the skip, which forgets the bytes after it. The bytes come SLOW_BYTE_MS
 * apart, the millisecond clock ticking. */
static void arrive_for_another_servo(const uint8_t *packet, size_t arriving) {
  for (size_t i = 0; i < arriving; i++) {
    tick_ms(SLOW_BYTE_MS);
    assert_true(fake_uart_receive(&rig.uart, packet[i]));
    run();
  }
}

static void test_another_servos_packet_is_passed_over_between_two_of_ours(void **state) {
  (void)state;
  rig_up();
  arrive_armed(DXL_INST_PING, NULL, 0, true);
  sent();
  const uint8_t head = rig.uart.head;
  const uint64_t taken = rig.uart.taken_count;
  uint8_t packet[DXL_PACKET_MAX_BYTES];
  const uint8_t led_on[] = {CT_ADDR_LED, 1};
  const size_t length = packet_encode(packet, 2, DXL_INST_WRITE, led_on, sizeof led_on);
  assert_true(length * SLOW_BYTE_MS > DXL_PACKET_GAP_TIMEOUT_MS);
  arrive_for_another_servo(packet, length);
  assert_int_equal(rig.uart.skip, 0);
  assert_int_equal(rig.uart.frame.state, DXL_FRAME_SEARCH);
  assert_true(rig.uart.listening);
  assert_int_equal(rig.uart.head, head); /* none of its bytes in the ring, */
  assert_int_equal(rig.uart.taken_count, taken); /* none taken into the finder */
  assert_true(dxl_finder_idle(&rig.link.finder));
  assert_int_equal(rig.handled_count, 1);
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_IDLE);
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 0);
  clear_log();
  const uint8_t read[] = {CT_ADDR_ID, 1};
  const uint8_t id[] = {FACTORY_ID};
  arrive_armed(DXL_INST_READ, read, sizeof read, true);
  assert_log("armed start ");
  assert_reply(0, id, sizeof id);
  assert_int_equal(rig.handled_count, 2);
  assert_int_equal(rig.handled_instruction, DXL_INST_READ);
  assert_int_equal(rig.uart.taken_count, taken + PACKET_OVERHEAD + sizeof read); /* ours alone */
  sent();
}

static void test_a_header_or_a_skip_that_stops_ends_after_the_gap(void **state) {
  (void)state;
  uint8_t packet[DXL_PACKET_MAX_BYTES];
  const uint8_t led_on[] = {CT_ADDR_LED, 1};
  (void)packet_encode(packet, 2, DXL_INST_WRITE, led_on, sizeof led_on);
  /* FF, FF FF, FF FF ID: a header part-way; FF FF ID LENGTH, alone and with 2 of the 4 bytes
   * it counts: a skip. */
  static const size_t arriving[] = {1, 2, 3, 4, 6};
  for (size_t i = 0; i < sizeof arriving / sizeof arriving[0]; i++) {
    rig_up();
    arrive_for_another_servo(packet, arriving[i]);
    const uint8_t frame_state = rig.uart.frame.state;
    const uint8_t skip = rig.uart.skip;
    assert_true(skip != 0 || (frame_state != DXL_FRAME_SEARCH && frame_state <= DXL_FRAME_LENGTH));
    tick_ms(DXL_PACKET_GAP_TIMEOUT_MS); /* a byte now would still be the packet's */
    assert_int_equal(rig.uart.frame.state, frame_state);
    assert_int_equal(rig.uart.skip, skip);
    tick_ms(2); /* more than the gap: dropped */
    assert_int_equal(rig.uart.frame.state, DXL_FRAME_SEARCH);
    assert_int_equal(rig.uart.skip, 0);
    arrive_armed(DXL_INST_PING, NULL, 0, true); /* the next packet is answered */
    assert_reply(0, NULL, 0);
    assert_int_equal(rig.handled_count, 1);
    assert_int_equal(rig.handled_instruction, DXL_INST_PING);
    sent();
  }
}

/* docs/policy.md "Framing and bus": no packet spans a gap of more than 100 ms, even when its
 * first bytes wait in the ring behind a reply that is on the wire for longer than the gap. A PING
 * to this servo, then the first bytes of a WRITE to it; the gap passes with the PING's reply
 * still on the wire, then the rest of the WRITE comes. Once the reply has left, the link takes
 * what waited: the WRITE's two halves are not one packet. */
static void test_no_packet_spans_a_gap_while_a_reply_holds_up_the_bytes_before_it(void **state) {
  (void)state;
  rig_up();
  uint8_t write[DXL_PACKET_MAX_BYTES];
  const uint8_t led_on[] = {CT_ADDR_LED, 1};
  const size_t write_length = packet_encode(write, FACTORY_ID, DXL_INST_WRITE, led_on, sizeof led_on);
  const size_t before_gap = PACKET_OFS_INSTRUCTION + 1u; /* FF FF ID LENGTH INSTRUCTION */
  for (size_t i = before_gap; i < write_length; i++) {
    assert_int_not_equal(write[i], DXL_HEADER_BYTE); /* no header after the gap */
  }
  send(FACTORY_ID, DXL_INST_PING, NULL, 0);
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_SENDING);
  arrive(write, before_gap);
  assert_int_not_equal(rig.uart.head, rig.uart.tail); /* waiting behind the reply */
  tick_ms(DXL_PACKET_GAP_TIMEOUT_MS + 2u); /* the gap, the reply still on the wire */
  arrive(write + before_gap, write_length - before_gap);
  sent();
  tick_ms(DXL_PACKET_GAP_TIMEOUT_MS + 2u);
  assert_int_equal(rig.handled_count, 1); /* the PING alone */
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 0);
  assert_int_equal(rig.uart.reply_state, DXL_LINK_REPLY_IDLE);
  assert_true(dxl_finder_idle(&rig.link.finder));
  assert_int_equal(rig.uart.head, rig.uart.tail);
  /* and what follows is framed afresh */
  send(FACTORY_ID, DXL_INST_WRITE, led_on, sizeof led_on);
  sent();
  assert_int_equal(rig.servo.table[CT_ADDR_LED], 1);
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
      cmocka_unit_test(test_each_status_return_level_answers_each_instruction_as_the_policy_says),
      cmocka_unit_test(test_a_bad_checksum_gets_a_checksum_error),
      cmocka_unit_test(test_garbage_and_other_servos_packets_between_ours_are_passed_over),
      cmocka_unit_test(test_packets_that_come_during_a_reply_wait_for_its_end),
      cmocka_unit_test(test_an_armed_ping_is_answered_by_the_uart_with_the_ready_reply),
      cmocka_unit_test(test_an_armed_read_is_published_before_its_checksum_and_committed_after),
      cmocka_unit_test(test_an_armed_eeprom_write_is_stored_after_its_checksum),
      cmocka_unit_test(test_an_armed_packet_with_a_bad_checksum_is_answered_from_the_finder),
      cmocka_unit_test(test_an_armed_packet_whose_checksum_never_comes_is_given_up),
      cmocka_unit_test(test_the_armed_path_asks_the_delay_of_every_return_delay_time),
      cmocka_unit_test(test_an_action_to_this_servo_is_answered_after_a_registered_write),
      cmocka_unit_test(test_a_broadcast_ping_is_answered_in_profile_ax12_only),
      cmocka_unit_test(test_the_ready_ping_reply_is_rebuilt_when_its_error_byte_would_change),
      cmocka_unit_test(test_the_ready_ping_reply_follows_the_conditions_through_a_protocol2_frame),
      cmocka_unit_test(test_another_servos_packet_is_passed_over_between_two_of_ours),
      cmocka_unit_test(test_a_header_or_a_skip_that_stops_ends_after_the_gap),
      cmocka_unit_test(test_no_packet_spans_a_gap_while_a_reply_holds_up_the_bytes_before_it),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
