/* The bootloader's protocol (firmware/boot/boot_protocol.h) and framer (boot_frame.h) on the
 * host, with the flash an array behind boot_port.h: every instruction and error of
 * docs/bootloader.md "Packets", the record's life through an update, a cut at every step of an
 * update leaving an application that is not valid, and the framer against noise, gaps and
 * other servos' packets. Built once per part (test/boot/CMakeLists.txt). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "boot_frame.h"
#include "boot_image.h"
#include "boot_port.h"
#include "boot_protocol.h"
#include "dxl_image.h"
#include "dxl_protocol.h"

#define SERVO_ID 7u
#define APP_BYTES ((uint16_t)(BOOT_PAGE_BYTES * 5u + 10u)) /* a partial last page */

/* The part's flash, and how the fake programs it. */
static uint8_t flash[BOOT_FLASH_BYTES];
static unsigned programs;       /* pages programmed */
static int fail_program_at = -1; /* this programming leaves a wrong byte (a worn page) */

uint8_t boot_port_flash_byte(uint16_t address) {
  assert_true(address < BOOT_FLASH_BYTES);
  return flash[address];
}

void boot_port_flash_program(uint16_t page_address, const uint8_t *bytes) {
  assert_int_equal(page_address % BOOT_PAGE_BYTES, 0);
  assert_true(page_address < BOOT_START); /* never the boot section */
  memcpy(&flash[page_address], bytes, BOOT_PAGE_BYTES);
  if ((int)programs == fail_program_at) {
    flash[page_address + 3u] ^= 0x01u;
  }
  programs++;
}

static uint8_t image[BOOT_FLASH_BYTES];

static void make_image(uint8_t seed) {
  for (uint16_t i = 0; i < APP_BYTES; i++) {
    image[i] = (uint8_t)(i * 31u + seed);
  }
  memset(&image[APP_BYTES], 0xFF, sizeof image - APP_BYTES);
}

static uint16_t image_crc(void) { return boot_crc_bytes(BOOT_CRC_INITIAL, image, APP_BYTES); }

static int setup(void **state) {
  (void)state;
  memset(flash, 0xFF, sizeof flash);
  memset(&flash[BOOT_START], 0x5A, BOOT_SECTION_BYTES); /* the bootloader's own code */
  programs = 0;
  fail_program_at = -1;
  make_image(1);
  return 0;
}

/* One request through boot_handle(); returns the reply's length, its bytes in reply. */
static uint8_t reply[BOOT_REPLY_MAX_BYTES];

static uint8_t request(boot_t *boot, uint8_t id, uint8_t instruction, const uint8_t *params, uint8_t count) {
  const dxl_packet_t packet = {id, instruction, count, params, 0};
  memset(reply, 0xEE, sizeof reply);
  return boot_handle(boot, &packet, reply);
}

/* The reply is a well-formed status packet of this servo with this error and count params. */
static void assert_status(uint8_t length, uint8_t error, uint8_t param_count) {
  assert_int_equal(length, param_count + 6u);
  assert_int_equal(reply[0], 0xFF);
  assert_int_equal(reply[1], 0xFF);
  assert_int_equal(reply[2], SERVO_ID);
  assert_int_equal(reply[3], param_count + 2u);
  assert_int_equal(reply[4], error);
  uint8_t sum = 0;
  for (uint8_t i = 2; i < length - 1u; i++) {
    sum = (uint8_t)(sum + reply[i]);
  }
  assert_int_equal(reply[length - 1u], (uint8_t)~sum);
}

static uint8_t begin(boot_t *boot, uint16_t length, uint16_t crc) {
  const uint8_t params[4] = {(uint8_t)length, (uint8_t)(length >> 8), (uint8_t)crc, (uint8_t)(crc >> 8)};
  return request(boot, SERVO_ID, BOOT_INST_BEGIN, params, 4);
}

static uint8_t page(boot_t *boot, uint16_t address, const uint8_t *data, uint16_t crc) {
  uint8_t params[4u + BOOT_PAGE_BYTES];
  params[0] = (uint8_t)address;
  params[1] = (uint8_t)(address >> 8);
  params[2] = (uint8_t)crc;
  params[3] = (uint8_t)(crc >> 8);
  memcpy(&params[4], data, BOOT_PAGE_BYTES);
  return request(boot, SERVO_ID, BOOT_INST_PAGE, params, sizeof params);
}

static uint8_t good_page(boot_t *boot, uint16_t address) {
  return page(boot, address, &image[address], boot_crc_bytes(BOOT_CRC_INITIAL, &image[address], BOOT_PAGE_BYTES));
}

/* A whole update as the flasher makes it; returns the first error. */
static uint8_t update(boot_t *boot) {
  uint8_t length = begin(boot, APP_BYTES, image_crc());
  if (reply[4] != 0) {
    return reply[4];
  }
  for (uint16_t address = 0; address < APP_BYTES; address = (uint16_t)(address + BOOT_PAGE_BYTES)) {
    length = good_page(boot, address);
    if (reply[4] != 0) {
      return reply[4];
    }
  }
  length = request(boot, SERVO_ID, BOOT_INST_END, NULL, 0);
  assert_status(length, reply[4], 0);
  return reply[4];
}

static void test_info_names_the_part_and_the_state(void **state) {
  (void)state;
  boot_t boot;
  boot_init(&boot, SERVO_ID, BOOT_STATE_BY_REQUEST);
  const uint8_t length = request(&boot, SERVO_ID, BOOT_INST_INFO, NULL, 0);
  assert_status(length, 0, BOOT_INFO_BYTES);
  const uint8_t expected[BOOT_INFO_BYTES] = {'A', 'X', 'B', 'L', BOOT_VERSION, BOOT_SIGNATURE_0, BOOT_SIGNATURE_1,
                                             BOOT_SIGNATURE_2, BOOT_PAGE_BYTES, 0, (uint8_t)BOOT_START,
                                             (uint8_t)(BOOT_START >> 8), BOOT_STATE_BY_REQUEST};
  assert_memory_equal(&reply[5], expected, BOOT_INFO_BYTES);
  assert_int_equal(update(&boot), 0);
  request(&boot, SERVO_ID, BOOT_INST_INFO, NULL, 0);
  assert_int_equal(reply[5 + 12], BOOT_STATE_BY_REQUEST | BOOT_STATE_APP_VALID);
}

static void test_an_update_writes_the_image_and_then_the_record(void **state) {
  (void)state;
  boot_t boot;
  boot_init(&boot, SERVO_ID, 0);
  assert_false(boot_app_valid());
  assert_int_equal(update(&boot), 0);
  assert_memory_equal(flash, image, APP_BYTES);
  uint8_t record[BOOT_RECORD_BYTES];
  boot_record_build(record, APP_BYTES, image_crc());
  assert_memory_equal(&flash[BOOT_RECORD_ADDRESS], record, BOOT_RECORD_BYTES);
  for (uint16_t i = BOOT_RECORD_BYTES; i < BOOT_PAGE_BYTES; i++) {
    assert_int_equal(flash[BOOT_RECORD_ADDRESS + i], 0xFF);
  }
  assert_true(boot_app_valid());
  for (uint16_t i = 0; i < BOOT_SECTION_BYTES; i++) {
    assert_int_equal(flash[BOOT_START + i], 0x5A);
  }
  assert_int_equal(request(&boot, SERVO_ID, BOOT_INST_GO, NULL, 0), 6);
  assert_int_equal(reply[4], 0);
  assert_true(boot.start_app);
}

static void test_a_cut_at_any_step_leaves_no_valid_application(void **state) {
  (void)state;
  /* An earlier application, valid; then an update of another image cut after each step. */
  boot_t boot;
  boot_init(&boot, SERVO_ID, 0);
  assert_int_equal(update(&boot), 0);
  assert_true(boot_app_valid());
  const uint8_t pages = (uint8_t)((APP_BYTES + BOOT_PAGE_BYTES - 1u) / BOOT_PAGE_BYTES);
  for (uint8_t steps = 0; steps <= pages; steps++) {
    make_image((uint8_t)(2u + steps));
    boot_init(&boot, SERVO_ID, 0); /* a reset after the cut forgets BEGIN */
    begin(&boot, APP_BYTES, image_crc());
    for (uint8_t p = 0; p < steps; p++) {
      good_page(&boot, (uint16_t)(p * BOOT_PAGE_BYTES));
    }
    boot_init(&boot, SERVO_ID, 0);
    assert_false(boot_app_valid());
    request(&boot, SERVO_ID, BOOT_INST_END, NULL, 0);
    assert_int_equal(reply[4], BOOT_ERROR_RANGE); /* END needs BEGIN again */
    request(&boot, SERVO_ID, BOOT_INST_GO, NULL, 0);
    assert_int_equal(reply[4], BOOT_ERROR_CRC);
    assert_false(boot.start_app);
  }
  assert_int_equal(update(&boot), 0); /* and a new update completes */
  assert_true(boot_app_valid());
}

static void test_end_refuses_an_image_whose_crc_differs(void **state) {
  (void)state;
  boot_t boot;
  boot_init(&boot, SERVO_ID, 0);
  begin(&boot, APP_BYTES, (uint16_t)(image_crc() ^ 1u));
  for (uint16_t address = 0; address < APP_BYTES; address = (uint16_t)(address + BOOT_PAGE_BYTES)) {
    good_page(&boot, address);
    assert_int_equal(reply[4], 0);
  }
  assert_status(request(&boot, SERVO_ID, BOOT_INST_END, NULL, 0), BOOT_ERROR_CRC, 0);
  assert_false(boot_app_valid());
  assert_int_equal(flash[BOOT_RECORD_ADDRESS], 0xFF);
}

static void test_page_errors(void **state) {
  (void)state;
  boot_t boot;
  boot_init(&boot, SERVO_ID, 0);
  assert_status(good_page(&boot, 0), BOOT_ERROR_RANGE, 0); /* before BEGIN */
  assert_int_equal(programs, 0);
  begin(&boot, APP_BYTES, image_crc());
  const unsigned after_begin = programs;
  const uint16_t crc0 = boot_crc_bytes(BOOT_CRC_INITIAL, image, BOOT_PAGE_BYTES);
  assert_status(page(&boot, 0, image, (uint16_t)(crc0 ^ 0x100u)), BOOT_ERROR_CRC, 0);
  assert_status(page(&boot, 1, image, crc0), BOOT_ERROR_RANGE, 0);                      /* not aligned */
  assert_status(page(&boot, BOOT_RECORD_ADDRESS, image, crc0), BOOT_ERROR_RANGE, 0);    /* the record */
  assert_status(page(&boot, BOOT_START, image, crc0), BOOT_ERROR_RANGE, 0);             /* the bootloader */
  assert_int_equal(programs, after_begin); /* nothing written for any of them */
  fail_program_at = (int)programs;
  assert_status(good_page(&boot, 0), BOOT_ERROR_PROGRAM, 0);
  assert_status(good_page(&boot, 0), 0, 0); /* a retry of the page */
  /* A PAGE one byte short is the wrong parameter count. */
  uint8_t params[4u + BOOT_PAGE_BYTES];
  memset(params, 0, sizeof params);
  assert_status(request(&boot, SERVO_ID, BOOT_INST_PAGE, params, sizeof params - 1u), BOOT_ERROR_INSTRUCTION, 0);
}

static void test_begin_refuses_a_length_beyond_the_application_area(void **state) {
  (void)state;
  boot_t boot;
  boot_init(&boot, SERVO_ID, 0);
  assert_status(begin(&boot, 0, 0), BOOT_ERROR_RANGE, 0);
  assert_status(begin(&boot, (uint16_t)(BOOT_RECORD_ADDRESS + 1u), 0), BOOT_ERROR_RANGE, 0);
  assert_int_equal(programs, 0);
  assert_status(begin(&boot, BOOT_RECORD_ADDRESS, 0), 0, 0);
}

static void test_read_returns_a_page_of_the_application_area(void **state) {
  (void)state;
  boot_t boot;
  boot_init(&boot, SERVO_ID, 0);
  assert_int_equal(update(&boot), 0);
  const uint8_t at[2] = {(uint8_t)BOOT_PAGE_BYTES, (uint8_t)(BOOT_PAGE_BYTES >> 8)};
  assert_status(request(&boot, SERVO_ID, BOOT_INST_READ, at, 2), 0, BOOT_PAGE_BYTES);
  assert_memory_equal(&reply[5], &image[BOOT_PAGE_BYTES], BOOT_PAGE_BYTES);
  const uint8_t record_at[2] = {(uint8_t)BOOT_RECORD_ADDRESS, (uint8_t)(BOOT_RECORD_ADDRESS >> 8)};
  assert_status(request(&boot, SERVO_ID, BOOT_INST_READ, record_at, 2), 0, BOOT_PAGE_BYTES);
  const uint8_t boot_at[2] = {(uint8_t)BOOT_START, (uint8_t)(BOOT_START >> 8)};
  assert_status(request(&boot, SERVO_ID, BOOT_INST_READ, boot_at, 2), BOOT_ERROR_RANGE, 0);
  const uint8_t odd[2] = {3, 0};
  assert_status(request(&boot, SERVO_ID, BOOT_INST_READ, odd, 2), BOOT_ERROR_RANGE, 0);
}

static void test_other_ids_broadcast_and_unknown_instructions(void **state) {
  (void)state;
  boot_t boot;
  boot_init(&boot, SERVO_ID, 0);
  assert_int_equal(request(&boot, SERVO_ID + 1u, BOOT_INST_PING, NULL, 0), 0);
  assert_int_equal(request(&boot, 0xFEu, BOOT_INST_PING, NULL, 0), 0);
  assert_int_equal(request(&boot, 0xFEu, BOOT_INST_BEGIN, (const uint8_t *)"\x10\x00\x00\x00", 4), 0);
  assert_int_equal(programs, 0);
  assert_status(request(&boot, SERVO_ID, BOOT_INST_PING, NULL, 0), 0, 0);
  assert_status(request(&boot, SERVO_ID, BOOT_INST_PING, (const uint8_t *)"x", 1), BOOT_ERROR_INSTRUCTION, 0);
  assert_status(request(&boot, SERVO_ID, 0x03u, (const uint8_t *)"\x1e\x00\x02", 3), BOOT_ERROR_INSTRUCTION, 0);
  assert_status(request(&boot, SERVO_ID, 0x26u, NULL, 0), BOOT_ERROR_INSTRUCTION, 0);
  assert_status(request(&boot, SERVO_ID, BOOT_INST_ENTER, (const uint8_t *)"BOOT", 4), 0, 0);
  assert_status(request(&boot, SERVO_ID, BOOT_INST_ENTER, (const uint8_t *)"BOOX", 4), BOOT_ERROR_INSTRUCTION, 0);
  assert_status(request(&boot, SERVO_ID, BOOT_INST_GO, NULL, 0), BOOT_ERROR_CRC, 0);
  assert_false(boot.start_app);
}

/* The record: its bytes, and what parse accepts. */
static void test_record_build_and_parse(void **state) {
  (void)state;
  uint8_t record[BOOT_RECORD_BYTES];
  boot_record_build(record, 0x1234u, 0xBEEFu);
  const uint8_t expected[BOOT_RECORD_BYTES] = {'A', 'X', 'A', 'P', 0x34, 0x12, 0xEF, 0xBE};
  assert_memory_equal(record, expected, BOOT_RECORD_BYTES);
  uint16_t length = 0;
  uint16_t crc = 0;
  assert_true(boot_record_parse(record, 0x1234u, &length, &crc));
  assert_int_equal(length, 0x1234u);
  assert_int_equal(crc, 0xBEEFu);
  assert_false(boot_record_parse(record, 0x1233u, &length, &crc));
  record[2] = 'B';
  assert_false(boot_record_parse(record, 0x1234u, &length, &crc));
  boot_record_build(record, 0, 0);
  assert_false(boot_record_parse(record, 0x1234u, &length, &crc));
  /* The CRC is CRC-16/CCITT-FALSE: its check value. */
  assert_int_equal(boot_crc_bytes(BOOT_CRC_INITIAL, (const uint8_t *)"123456789", 9), 0x29B1u);
}

/* Feeds bytes at one millisecond each; returns the packets completed. */
static unsigned feed(boot_frame_t *frame, const uint8_t *bytes, unsigned count, uint16_t *now_ms,
                     dxl_packet_t *last) {
  unsigned packets = 0;
  for (unsigned i = 0; i < count; i++) {
    if (boot_frame_push(frame, bytes[i], (*now_ms)++, last)) {
      packets++;
    }
  }
  return packets;
}

static void test_framer(void **state) {
  (void)state;
  boot_frame_t frame;
  boot_frame_init(&frame);
  uint16_t now_ms = 0;
  dxl_packet_t packet;
  const uint8_t ping[] = {0xFF, 0xFF, 0x07, 0x02, 0x01, 0xF5};
  assert_int_equal(feed(&frame, ping, sizeof ping, &now_ms, &packet), 1);
  assert_int_equal(packet.id, 7);
  assert_int_equal(packet.instruction, 1);
  assert_int_equal(packet.param_count, 0);
  /* Garbage, extra 0xFF before the ID, then a READ with parameters. */
  const uint8_t read[] = {0x00, 0x13, 0xFF, 0x55, 0xFF, 0xFF, 0xFF, 0x07, 0x04, 0x02, 0x2B, 0x01, 0xC6};
  assert_int_equal(feed(&frame, read, sizeof read, &now_ms, &packet), 1);
  assert_int_equal(packet.instruction, 2);
  assert_int_equal(packet.param_count, 2);
  assert_int_equal(packet.params[0], 0x2B);
  assert_int_equal(packet.params[1], 0x01);
  /* Another servo's packet whose parameters hold a whole packet for 7: framed by its LENGTH,
   * the inner one is not taken. */
  const uint8_t other[] = {0xFF, 0xFF, 0x08, 0x08, 0x03, 0xFF, 0xFF, 0x07, 0x02, 0x01, 0xF5, 0xEF};
  assert_int_equal(feed(&frame, other, sizeof other, &now_ms, &packet), 1);
  assert_int_equal(packet.id, 8);
  assert_int_equal(packet.param_count, 6);
  /* A wrong checksum: nothing; the next packet is still found. */
  const uint8_t bad[] = {0xFF, 0xFF, 0x07, 0x02, 0x01, 0xF4};
  assert_int_equal(feed(&frame, bad, sizeof bad, &now_ms, &packet), 0);
  assert_int_equal(feed(&frame, ping, sizeof ping, &now_ms, &packet), 1);
  /* A LENGTH below 2 or above the largest PAGE drops the header. */
  const uint8_t short_length[] = {0xFF, 0xFF, 0x07, 0x01};
  assert_int_equal(feed(&frame, short_length, sizeof short_length, &now_ms, &packet), 0);
  assert_int_equal(feed(&frame, ping, sizeof ping, &now_ms, &packet), 1);
  const uint8_t long_length[] = {0xFF, 0xFF, 0x07, (uint8_t)(BOOT_FRAME_MAX_LENGTH + 1u)};
  assert_int_equal(feed(&frame, long_length, sizeof long_length, &now_ms, &packet), 0);
  assert_int_equal(feed(&frame, ping, sizeof ping, &now_ms, &packet), 1);
  /* A gap of more than 100 ms drops a partial packet; 100 ms does not. */
  assert_int_equal(feed(&frame, ping, 3, &now_ms, &packet), 0);
  now_ms = (uint16_t)(now_ms + DXL_PACKET_GAP_TIMEOUT_MS);
  assert_int_equal(feed(&frame, &ping[3], 3, &now_ms, &packet), 0);
  assert_int_equal(feed(&frame, ping, sizeof ping, &now_ms, &packet), 1);
  assert_int_equal(feed(&frame, ping, 3, &now_ms, &packet), 0);
  now_ms = (uint16_t)(now_ms + DXL_PACKET_GAP_TIMEOUT_MS - 1u);
  assert_int_equal(feed(&frame, &ping[3], 3, &now_ms, &packet), 1);
}

/* The longest packet the bootloader takes, a PAGE, fits the framer whole. */
static void test_framer_takes_a_whole_page(void **state) {
  (void)state;
  boot_frame_t frame;
  boot_frame_init(&frame);
  uint8_t bytes[6u + 4u + BOOT_PAGE_BYTES];
  bytes[0] = bytes[1] = 0xFF;
  bytes[2] = SERVO_ID;
  bytes[3] = (uint8_t)(4u + BOOT_PAGE_BYTES + 2u);
  bytes[4] = BOOT_INST_PAGE;
  for (unsigned i = 5; i < sizeof bytes - 1u; i++) {
    bytes[i] = 0xFF; /* header bytes inside the data change nothing */
  }
  uint8_t sum = 0;
  for (unsigned i = 2; i < sizeof bytes - 1u; i++) {
    sum = (uint8_t)(sum + bytes[i]);
  }
  bytes[sizeof bytes - 1u] = (uint8_t)~sum;
  uint16_t now_ms = 0;
  dxl_packet_t packet;
  assert_int_equal(feed(&frame, bytes, sizeof bytes, &now_ms, &packet), 1);
  assert_int_equal(packet.param_count, 4u + BOOT_PAGE_BYTES);
  assert_true(4u + BOOT_PAGE_BYTES + 2u <= BOOT_FRAME_MAX_LENGTH);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test_setup(test_info_names_the_part_and_the_state, setup),
      cmocka_unit_test_setup(test_an_update_writes_the_image_and_then_the_record, setup),
      cmocka_unit_test_setup(test_a_cut_at_any_step_leaves_no_valid_application, setup),
      cmocka_unit_test_setup(test_end_refuses_an_image_whose_crc_differs, setup),
      cmocka_unit_test_setup(test_page_errors, setup),
      cmocka_unit_test_setup(test_begin_refuses_a_length_beyond_the_application_area, setup),
      cmocka_unit_test_setup(test_read_returns_a_page_of_the_application_area, setup),
      cmocka_unit_test_setup(test_other_ids_broadcast_and_unknown_instructions, setup),
      cmocka_unit_test(test_record_build_and_parse),
      cmocka_unit_test(test_framer),
      cmocka_unit_test(test_framer_takes_a_whole_page),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
