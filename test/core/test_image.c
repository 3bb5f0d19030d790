/* The persistent EEPROM image (dxl_image.h): layout, CRC-8 and its integrity check. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "dxl_image.h"
#include "dxl_servo.h"

/* CRC-8 with polynomial 0x07, initial value 0, no reflection, no final XOR (CRC-8/SMBUS),
 * computed here the long way: polynomial division of the message followed by 8 zero bits. */
static uint8_t independent_crc8(const uint8_t *data, size_t count) {
  unsigned remainder = 0; /* 9-bit work register */
  for (size_t i = 0; i < count + 1u; i++) {
    const uint8_t byte = i < count ? data[i] : 0u;
    for (int bit = 7; bit >= 0; bit--) {
      remainder = (remainder << 1) | ((byte >> bit) & 1u);
      if (remainder & 0x100u) {
        remainder ^= 0x107u;
      }
    }
  }
  return (uint8_t)remainder;
}

static void factory_image(uint8_t image[DXL_IMAGE_BYTES]) {
  dxl_servo_t servo;
  dxl_servo_power_up(&servo, NULL, 512);
  dxl_image_build(image, servo.table);
}

static void test_crc8_of_the_standard_check_string_is_f4(void **state) {
  (void)state;
  /* The catalogue check value of CRC-8/SMBUS over "123456789". */
  assert_int_equal(dxl_crc8((const uint8_t *)"123456789", 9), 0xF4);
  assert_int_equal(independent_crc8((const uint8_t *)"123456789", 9), 0xF4);
  assert_int_equal(dxl_crc8(NULL, 0), 0x00);
  assert_int_equal(dxl_crc8((const uint8_t[]){0x01}, 1), 0x07);
  assert_int_equal(dxl_crc8((const uint8_t[]){0x80}, 1), 0x89); /* hand-computed: 0x80 -> 0x07,0x0E,...,0x89 */
}

static void test_crc8_agrees_with_an_independent_implementation(void **state) {
  (void)state;
  uint8_t data[255];
  uint32_t x = 12345u;
  for (size_t n = 0; n < sizeof data; n++) {
    x = x * 1103515245u + 12345u;
    data[n] = (uint8_t)(x >> 16);
    assert_int_equal(dxl_crc8(data, (uint8_t)(n + 1u)), independent_crc8(data, n + 1u));
  }
}

static void test_an_image_is_version_table_and_crc(void **state) {
  (void)state;
  dxl_servo_t servo;
  dxl_servo_power_up(&servo, NULL, 512);
  uint8_t image[DXL_IMAGE_BYTES];
  dxl_image_build(image, servo.table);
  assert_int_equal(DXL_IMAGE_BYTES, 26);
  assert_int_equal(image[0], DXL_IMAGE_FORMAT_VERSION);
  assert_memory_equal(&image[1], servo.table, CT_EEPROM_SIZE);
  assert_int_equal(image[25], independent_crc8(image, 25));
  assert_true(dxl_image_is_valid(image));
}

static void test_an_image_of_another_version_is_invalid(void **state) {
  (void)state;
  uint8_t image[DXL_IMAGE_BYTES];
  factory_image(image);
  image[DXL_IMAGE_OFS_VERSION] = DXL_IMAGE_FORMAT_VERSION + 1u;
  image[DXL_IMAGE_OFS_CRC] = independent_crc8(image, DXL_IMAGE_OFS_CRC); /* a consistent image of it */
  assert_false(dxl_image_is_valid(image));
}

static void test_every_single_bit_flip_of_a_valid_image_is_detected(void **state) {
  (void)state;
  uint8_t image[DXL_IMAGE_BYTES];
  factory_image(image);
  for (size_t byte = 0; byte < DXL_IMAGE_BYTES; byte++) {
    for (unsigned bit = 0; bit < 8; bit++) {
      image[byte] ^= (uint8_t)(1u << bit);
      if (dxl_image_is_valid(image)) {
        fail_msg("flip of bit %u of byte %zu not detected", bit, byte);
      }
      image[byte] ^= (uint8_t)(1u << bit);
    }
  }
  assert_true(dxl_image_is_valid(image));
}

static void test_erased_and_blank_eeprom_are_invalid(void **state) {
  (void)state;
  uint8_t image[DXL_IMAGE_BYTES];
  memset(image, 0xFF, sizeof image);
  assert_false(dxl_image_is_valid(image));
  memset(image, 0x00, sizeof image);
  assert_false(dxl_image_is_valid(image));
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_crc8_of_the_standard_check_string_is_f4),
      cmocka_unit_test(test_crc8_agrees_with_an_independent_implementation),
      cmocka_unit_test(test_an_image_is_version_table_and_crc),
      cmocka_unit_test(test_an_image_of_another_version_is_invalid),
      cmocka_unit_test(test_every_single_bit_flip_of_a_valid_image_is_detected),
      cmocka_unit_test(test_erased_and_blank_eeprom_are_invalid),
  };
  return cmocka_run_group_tests_name("EEPROM image (" AX12_PROFILE_NAME ")", tests, NULL, NULL);
}
