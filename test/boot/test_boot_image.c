/* The application record (firmware/boot/boot_image.h) on the host: Fletcher-16 against values
 * worked by hand, the record's bytes, and boot_app_valid() (the bootloader's decision at
 * reset, which test/sim/test_bootloader.c checks on the real bootloader) on the flash sizes
 * of both parts: a whole image, a changed byte, an erased record, a record naming bytes in
 * the boot section. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "boot_image.h"

static uint8_t flash[32768];

static void test_the_check_value_is_fletcher_16_modulo_256(void **state) {
  (void)state;
  assert_int_equal(boot_check_bytes(0, NULL, 0), 0x0000);
  /* 01 02: sum1 1, 3; sum2 1, 4. */
  assert_int_equal(boot_check_bytes(0, (const uint8_t[]){0x01, 0x02}, 2), 0x0403);
  /* FF FF: sum1 0xFF, 0xFE (mod 256); sum2 0xFF, 0xFD. */
  assert_int_equal(boot_check_bytes(0, (const uint8_t[]){0xFF, 0xFF}, 2), 0xFDFE);
  /* Continued from a check value, as over two pieces. */
  const uint8_t bytes[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  assert_int_equal(boot_check_bytes(boot_check_bytes(0, bytes, 4), &bytes[4], 5), boot_check_bytes(0, bytes, 9));
  /* Order matters (a plain sum would miss it). */
  assert_int_not_equal(boot_check_bytes(0, (const uint8_t[]){0x01, 0x02}, 2),
                       boot_check_bytes(0, (const uint8_t[]){0x02, 0x01}, 2));
}

static void test_the_record_names_the_last_byte_and_the_check_value(void **state) {
  (void)state;
  uint8_t record[BOOT_RECORD_BYTES];
  boot_record_build(record, 0x1234, 0xBEEF);
  const uint8_t expected[] = {0x33, 0x12, 0xEF, 0xBE};
  assert_memory_equal(record, expected, sizeof expected);
  uint32_t length;
  uint16_t check;
  assert_true(boot_record_parse(record, 0x1E00, &length, &check));
  assert_int_equal(length, 0x1234);
  assert_int_equal(check, 0xBEEF);
  /* Erased: its last byte would be in the boot section. */
  assert_false(boot_record_parse((const uint8_t[]){0xFF, 0xFF, 0xFF, 0xFF}, 0x7E00, &length, &check));
  /* The last byte just below the boot section: taken (the record's own bytes then count). */
  assert_true(boot_record_parse((const uint8_t[]){0xFF, 0x1D, 0, 0}, 0x1E00, &length, &check));
  assert_false(boot_record_parse((const uint8_t[]){0x00, 0x1E, 0, 0}, 0x1E00, &length, &check));
}

static void check_validity_on(uint32_t flash_bytes) {
  const uint16_t boot_start = boot_section_start(flash_bytes);
  const uint16_t record_at = boot_record_address(boot_start);
  assert_int_equal(record_at, boot_start - 4u);
  memset(flash, 0xFF, sizeof flash);
  const uint32_t length = 7000;
  for (uint32_t i = 0; i < length; i++) {
    flash[i] = (uint8_t)(i * 7u + 3u);
  }
  assert_false(boot_app_valid(flash, flash_bytes)); /* erased record */
  boot_record_build(&flash[record_at], length, boot_check_bytes(0, flash, length));
  assert_true(boot_app_valid(flash, flash_bytes));
  flash[4321] ^= 0x10u;
  assert_false(boot_app_valid(flash, flash_bytes));
  flash[4321] ^= 0x10u;
  flash[length] = 0x00; /* past the image: not part of it */
  assert_true(boot_app_valid(flash, flash_bytes));
  flash[record_at + 2u] ^= 0x01u; /* the record's own check value */
  assert_false(boot_app_valid(flash, flash_bytes));
}

static void test_validity_on_the_atmega88(void **state) {
  (void)state;
  assert_int_equal(boot_section_start(8192), 0x1E00);
  check_validity_on(8192);
}

static void test_validity_on_the_atmega328p(void **state) {
  (void)state;
  assert_int_equal(boot_section_start(32768), 0x7E00);
  check_validity_on(32768);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_the_check_value_is_fletcher_16_modulo_256),
      cmocka_unit_test(test_the_record_names_the_last_byte_and_the_check_value),
      cmocka_unit_test(test_validity_on_the_atmega88),
      cmocka_unit_test(test_validity_on_the_atmega328p),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
