/* The persistent settings (dxl_image.h): two slots, CRC-16 over format, sequence and table,
 * the newest valid slot boots, and a write cut at any byte boots the old or the new settings. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "dxl_image.h"
#include "dxl_servo.h"
#include "eeprom_model.h"
#include "xorshift32.h"

/* CRC-16/CCITT-FALSE (polynomial 0x1021, initial 0xFFFF, no reflection, no final XOR) the
 * long way: the message, prefixed by the complement of the initial value's effect, divided
 * bit by bit in a 17-bit register. */
static uint16_t independent_crc16(const uint8_t *data, size_t count) {
  uint32_t reg = 0xFFFFu;
  for (size_t i = 0; i < count; i++) {
    for (int bit = 7; bit >= 0; bit--) {
      const uint32_t in = (uint32_t)((data[i] >> bit) & 1u);
      const uint32_t top = ((reg >> 15) & 1u) ^ in;
      reg = (reg << 1) & 0xFFFFu;
      if (top) {
        reg ^= 0x1021u;
      }
    }
  }
  return (uint16_t)reg;
}

static uint16_t crc16_of(const uint8_t *data, size_t count) {
  uint16_t crc = 0xFFFFu;
  for (size_t i = 0; i < count; i++) {
    crc = dxl_crc16_update(crc, data[i]);
  }
  return crc;
}

static void factory_area(uint8_t area[CT_EEPROM_SIZE]) {
  dxl_servo_t servo;
  dxl_servo_power_up(&servo, NULL, 512);
  memcpy(area, servo.table, CT_EEPROM_SIZE);
}

static void test_crc16_of_the_standard_check_string_is_29b1(void **state) {
  (void)state;
  /* The catalogue check value of CRC-16/CCITT-FALSE over "123456789". */
  assert_int_equal(crc16_of((const uint8_t *)"123456789", 9), 0x29B1);
  assert_int_equal(independent_crc16((const uint8_t *)"123456789", 9), 0x29B1);
}

static void test_crc16_agrees_with_an_independent_implementation(void **state) {
  (void)state;
  uint8_t data[255];
  uint32_t x = 12345u;
  for (size_t n = 0; n < sizeof data; n++) {
    data[n] = (uint8_t)xorshift32_next(&x);
    assert_int_equal(crc16_of(data, n + 1u), independent_crc16(data, n + 1u));
  }
}

static void test_a_slot_is_sequence_table_and_crc_of_format_sequence_and_table(void **state) {
  (void)state;
  uint8_t area[CT_EEPROM_SIZE];
  factory_area(area);
  uint8_t slot[DXL_IMAGE_SLOT_BYTES];
  dxl_image_slot_build(slot, area, 0x5A);
  assert_int_equal(DXL_IMAGE_SLOT_BYTES, 27);
  assert_int_equal(slot[0], 0x5A);
  assert_memory_equal(&slot[1], area, CT_EEPROM_SIZE);
  uint8_t covered[1 + 25];
  covered[0] = DXL_IMAGE_FORMAT_VERSION;
  memcpy(&covered[1], slot, 25);
  const uint16_t crc = independent_crc16(covered, sizeof covered);
  assert_int_equal(slot[25], crc & 0xFFu);
  assert_int_equal(slot[26], crc >> 8);
  assert_true(dxl_image_slot_is_valid(slot));
}

static void test_a_new_image_holds_the_settings_in_both_slots_slot_1_newest(void **state) {
  (void)state;
  uint8_t area[CT_EEPROM_SIZE];
  factory_area(area);
  uint8_t image[DXL_IMAGE_BYTES];
  dxl_image_build(image, area);
  assert_int_equal(dxl_image_newest_slot(image), 1);
  assert_ptr_equal(dxl_image_settings(image), &image[DXL_IMAGE_SLOT_STRIDE + DXL_IMAGE_OFS_TABLE]);
  assert_true(dxl_image_slot_is_valid(image));
  assert_memory_equal(&image[DXL_IMAGE_OFS_TABLE], area, CT_EEPROM_SIZE);
  assert_int_equal(image[DXL_IMAGE_OFS_SEQUENCE], 0);
  assert_int_equal(image[DXL_IMAGE_SLOT_STRIDE + DXL_IMAGE_OFS_SEQUENCE], 1);
  for (size_t i = DXL_IMAGE_SLOT_BYTES; i < DXL_IMAGE_SLOT_STRIDE; i++) {
    assert_int_equal(image[i], 0xFF); /* the gap between the slots stays blank */
  }
}

static void test_an_image_of_the_previous_format_is_invalid(void **state) {
  (void)state;
  /* Format 1: [0] version 1, [1..24] table, [25] CRC-8 (polynomial 0x07) of bytes 0..24. */
  uint8_t area[CT_EEPROM_SIZE];
  factory_area(area);
  uint8_t image[DXL_IMAGE_BYTES];
  memset(image, 0xFF, sizeof image);
  image[0] = 1;
  memcpy(&image[1], area, CT_EEPROM_SIZE);
  uint8_t crc = 0;
  for (size_t i = 0; i < 25; i++) {
    crc ^= image[i];
    for (int bit = 0; bit < 8; bit++) {
      crc = (crc & 0x80u) ? (uint8_t)((crc << 1) ^ 0x07u) : (uint8_t)(crc << 1);
    }
  }
  image[25] = crc;
  assert_int_equal(dxl_image_newest_slot(image), DXL_IMAGE_NO_SLOT);
  assert_null(dxl_image_settings(image));
}

static void test_every_change_of_one_byte_of_a_slot_is_detected(void **state) {
  (void)state;
  uint8_t area[CT_EEPROM_SIZE];
  factory_area(area);
  uint8_t slot[DXL_IMAGE_SLOT_BYTES];
  dxl_image_slot_build(slot, area, 3);
  for (size_t byte = 0; byte < DXL_IMAGE_SLOT_BYTES; byte++) {
    const uint8_t kept = slot[byte];
    for (unsigned value = 0; value < 256u; value++) {
      slot[byte] = (uint8_t)value;
      if (value != kept && dxl_image_slot_is_valid(slot)) {
        fail_msg("byte %zu = 0x%02X not detected", byte, value);
      }
    }
    slot[byte] = kept;
  }
  assert_true(dxl_image_slot_is_valid(slot));
}

static void test_erased_and_zeroed_eeprom_hold_no_settings(void **state) {
  (void)state;
  uint8_t image[DXL_IMAGE_BYTES];
  memset(image, 0xFF, sizeof image);
  assert_int_equal(dxl_image_newest_slot(image), DXL_IMAGE_NO_SLOT);
  memset(image, 0x00, sizeof image);
  assert_int_equal(dxl_image_newest_slot(image), DXL_IMAGE_NO_SLOT);
}

static void set_slot(uint8_t image[DXL_IMAGE_BYTES], uint8_t slot, uint8_t sequence, uint8_t id) {
  uint8_t area[CT_EEPROM_SIZE];
  factory_area(area);
  area[CT_ADDR_ID] = id;
  dxl_image_slot_build(&image[dxl_image_slot_offset(slot)], area, sequence);
}

static void test_of_two_valid_slots_the_one_ahead_in_sequence_boots(void **state) {
  (void)state;
  uint8_t image[DXL_IMAGE_BYTES];
  static const struct {
    uint8_t first, second, newest;
  } cases[] = {{0, 1, 1}, {1, 0, 0}, {5, 6, 1}, {6, 5, 0}, {255, 0, 1}, {0, 255, 0}, {254, 255, 1},
               {10, 137, 1}, {10, 138, 0} /* 128 apart: not ahead, the first stays */, {9, 9, 0}};
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    memset(image, 0xFF, sizeof image);
    set_slot(image, 0, cases[i].first, 10);
    set_slot(image, 1, cases[i].second, 20);
    assert_int_equal(dxl_image_newest_slot(image), cases[i].newest);
    assert_int_equal(dxl_image_settings(image)[CT_ADDR_ID], cases[i].newest == 0 ? 10 : 20);
  }
  /* One valid slot boots whatever its sequence number. */
  memset(image, 0xFF, sizeof image);
  set_slot(image, 1, 77, 20);
  assert_int_equal(dxl_image_newest_slot(image), 1);
  image[DXL_IMAGE_SLOT_STRIDE + 5] ^= 1u;
  set_slot(image, 0, 200, 10);
  assert_int_equal(dxl_image_newest_slot(image), 0);
}

static void test_the_sequence_number_is_written_last(void **state) {
  (void)state;
  bool seen[DXL_IMAGE_SLOT_BYTES] = {false};
  for (uint8_t step = 0; step < DXL_IMAGE_SLOT_BYTES; step++) {
    const uint8_t offset = dxl_image_write_offset(step);
    assert_true(offset < DXL_IMAGE_SLOT_BYTES);
    assert_false(seen[offset]);
    seen[offset] = true;
  }
  assert_int_equal(dxl_image_write_offset(DXL_IMAGE_SLOT_BYTES - 1u), DXL_IMAGE_OFS_SEQUENCE);
}

/* One store of area by the writer of firmware/hal/nvm.c (eeprom_model.h), booted from image
 * as it is: the slot not in use gets the new area with the next sequence number, in
 * dxl_image_write_offset() order, only the differing bytes. With cut_write >= 0 the write of
 * that number (0 = the first byte actually written) leaves garbage in its byte and nothing
 * after it is written. Returns the bytes written. */
static int write_settings(uint8_t image[DXL_IMAGE_BYTES], const uint8_t *area, int cut_write, uint8_t garbage) {
  eeprom_model_t model;
  memcpy(model.image, image, DXL_IMAGE_BYTES);
  (void)eeprom_model_boot(&model);
  eeprom_model_persist(&model, area);
  int written = 0;
  for (;;) {
    const bool cut = written == cut_write;
    if (!eeprom_model_service(&model, cut ? &garbage : NULL)) {
      break;
    }
    written++;
    if (cut) {
      break;
    }
  }
  memcpy(image, model.image, DXL_IMAGE_BYTES);
  return written;
}

static void random_valid_area(uint8_t area[CT_EEPROM_SIZE], uint32_t *rng) {
  factory_area(area);
  area[CT_ADDR_ID] = (uint8_t)(xorshift32_next(rng) % 254u);
  area[CT_ADDR_BAUD_RATE] = (uint8_t)(xorshift32_next(rng) % 255u);
  area[CT_ADDR_RETURN_DELAY_TIME] = (uint8_t)(xorshift32_next(rng) % 255u);
  ct_set_u16(area, CT_ADDR_CW_ANGLE_LIMIT, (uint16_t)(xorshift32_next(rng) % 1024u));
  ct_set_u16(area, CT_ADDR_CCW_ANGLE_LIMIT, (uint16_t)(xorshift32_next(rng) % 1024u));
  area[CT_ADDR_STATUS_RETURN_LEVEL] = (uint8_t)(xorshift32_next(rng) % 3u);
  area[CT_ADDR_ALARM_LED] = (uint8_t)(xorshift32_next(rng) % 128u);
}

/* The sweep: a servo's settings written again and again (each write a random set of items
 * changed from the last), and for every write, a cut at every byte it writes with every value
 * that byte can be left at. Every cut boots exactly the settings before the write or the new
 * ones. */
static void test_a_cut_at_any_byte_of_any_write_boots_the_old_or_the_new_settings(void **state) {
  (void)state;
  uint32_t rng = 0xC0FFEEu;
  uint8_t image[DXL_IMAGE_BYTES];
  memset(image, 0xFF, sizeof image);
  uint8_t old_area[CT_EEPROM_SIZE];
  factory_area(old_area);
  (void)write_settings(image, old_area, -1, 0);
  unsigned long cuts = 0;
  unsigned long booted_new = 0;
  for (int write = 0; write < 300; write++) {
    uint8_t new_area[CT_EEPROM_SIZE];
    memcpy(new_area, old_area, CT_EEPROM_SIZE);
    uint8_t random_area[CT_EEPROM_SIZE];
    random_valid_area(random_area, &rng);
    const uint32_t which = xorshift32_next(&rng); /* each address changes with probability 1/2 */
    for (uint8_t addr = 0; addr < CT_EEPROM_SIZE; addr++) {
      if (which & (1u << addr)) {
        new_area[addr] = random_area[addr];
      }
    }
    uint8_t scratch[DXL_IMAGE_BYTES];
    memcpy(scratch, image, sizeof scratch);
    const int total = write_settings(scratch, new_area, -1, 0);
    for (int cut = 0; cut < total; cut++) {
      for (unsigned garbage = 0; garbage < 256u; garbage++) {
        memcpy(scratch, image, sizeof scratch);
        (void)write_settings(scratch, new_area, cut, (uint8_t)garbage);
        const uint8_t *booted = dxl_image_settings(scratch);
        cuts++;
        if (booted == NULL || (memcmp(booted, old_area, CT_EEPROM_SIZE) != 0 &&
                               memcmp(booted, new_area, CT_EEPROM_SIZE) != 0)) {
          fail_msg("write %d: a cut at byte %d of %d left at 0x%02X boots %s", write, cut, total, garbage,
                   booted == NULL ? "no settings" : "a mix");
        }
        booted_new += memcmp(booted, new_area, CT_EEPROM_SIZE) == 0 && memcmp(old_area, new_area, CT_EEPROM_SIZE) != 0;
      }
    }
    (void)write_settings(image, new_area, -1, 0);
    assert_memory_equal(dxl_image_settings(image), new_area, CT_EEPROM_SIZE);
    memcpy(old_area, new_area, CT_EEPROM_SIZE);
  }
  print_message("%lu cuts, 0 boot a mix or nothing (%lu boot the new settings: cut in the last byte)\n", cuts,
                booted_new);
  assert_true(cuts > 100000u);
}

/* The writer under a stream of writes (docs/firmware.md "EEPROM write policy"): Max Torque
 * (two bytes) persisted anew every 1 ms for 2 s, on settings held in both slots, while each
 * EEPROM byte takes 3.4 ms. A store under way is never restarted, so every write is stored
 * (the last byte of its store complete) within 100 ms; and a cut at any byte (the byte left
 * at 0x00 or 0xFF) boots complete settings of a write no older than the last one stored. */
#define STREAM_MS 2000
#define BYTE_US 3400u
#define STORE_BOUND_MS 100
#define FACTORY_MAX_TORQUE 1023u

/* Max Torque of the write persisted at ms (never the factory value). */
static uint16_t stream_value(int ms) { return (uint16_t)(ms % 1000); }

/* Which write settings are: the newest persisted by now_ms with their Max Torque, -1 for the
 * settings before the stream. */
static int stream_write(const uint8_t *settings, int now_ms) {
  assert_non_null(settings);
  const uint16_t torque = ct_get_u16(settings, CT_ADDR_MAX_TORQUE);
  if (torque == FACTORY_MAX_TORQUE) {
    return -1;
  }
  int ms = now_ms < STREAM_MS ? now_ms : STREAM_MS - 1;
  while (ms >= 0 && stream_value(ms) != torque) {
    ms--;
  }
  if (ms < 0) {
    fail_msg("Max Torque %u was never written", torque);
  }
  return ms;
}

static void test_a_stream_of_writes_is_stored_within_100_ms_and_a_cut_never_loses_a_stored_one(void **state) {
  (void)state;
  uint8_t area[CT_EEPROM_SIZE];
  factory_area(area);
  assert_int_equal(ct_get_u16(area, CT_ADDR_MAX_TORQUE), FACTORY_MAX_TORQUE);
  eeprom_model_t model;
  dxl_image_build(model.image, area);
  (void)eeprom_model_boot(&model);
  uint32_t ready_at_us = 0;
  int stored = -1;
  int longest_ms = 0;
  unsigned cuts = 0;
  for (uint32_t t_us = 0; t_us < (STREAM_MS + STORE_BOUND_MS) * 1000u; t_us += 100u) {
    const int now_ms = (int)(t_us / 1000u);
    if (t_us % 1000u == 0 && now_ms < STREAM_MS) {
      ct_set_u16(area, CT_ADDR_MAX_TORQUE, stream_value(now_ms));
      eeprom_model_persist(&model, area);
    }
    if (t_us >= ready_at_us && eeprom_model_busy(&model)) {
      for (unsigned garbage = 0x00u; garbage <= 0xFFu; garbage += 0xFFu) {
        eeprom_model_t cut = model;
        const uint8_t torn = (uint8_t)garbage;
        (void)eeprom_model_service(&cut, &torn);
        const int booted = stream_write(dxl_image_settings(cut.image), now_ms);
        assert_true(booted >= stored);
        cuts++;
      }
      if (eeprom_model_service(&model, NULL)) {
        ready_at_us = t_us + BYTE_US;
      }
    }
    const int booted = stream_write(dxl_image_settings(model.image), now_ms);
    assert_true(booted >= stored); /* never back to an older write */
    stored = booted;
    /* every write persisted by then is in, its store's last byte complete 3.4 ms after it
     * started */
    const int due = (int)((t_us + BYTE_US) / 1000u) - STORE_BOUND_MS;
    if (due >= 0 && stored < (due < STREAM_MS ? due : STREAM_MS - 1)) {
      fail_msg("at %d ms the newest write stored is the one of %d ms", now_ms, stored);
    }
    if (now_ms < STREAM_MS) {
      longest_ms = now_ms - stored > longest_ms ? now_ms - stored : longest_ms;
    }
  }
  assert_int_equal(stored, STREAM_MS - 1);
  print_message("%u cuts, none lost a stored write; the stored write at most %d ms behind the newest\n", cuts,
                longest_ms);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_crc16_of_the_standard_check_string_is_29b1),
      cmocka_unit_test(test_crc16_agrees_with_an_independent_implementation),
      cmocka_unit_test(test_a_slot_is_sequence_table_and_crc_of_format_sequence_and_table),
      cmocka_unit_test(test_a_new_image_holds_the_settings_in_both_slots_slot_1_newest),
      cmocka_unit_test(test_an_image_of_the_previous_format_is_invalid),
      cmocka_unit_test(test_every_change_of_one_byte_of_a_slot_is_detected),
      cmocka_unit_test(test_erased_and_zeroed_eeprom_hold_no_settings),
      cmocka_unit_test(test_of_two_valid_slots_the_one_ahead_in_sequence_boots),
      cmocka_unit_test(test_the_sequence_number_is_written_last),
      cmocka_unit_test(test_a_cut_at_any_byte_of_any_write_boots_the_old_or_the_new_settings),
      cmocka_unit_test(test_a_stream_of_writes_is_stored_within_100_ms_and_a_cut_never_loses_a_stored_one),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
