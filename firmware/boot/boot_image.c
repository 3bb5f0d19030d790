/* The application record. See boot_image.h. */
#include "boot_image.h"

#include "dxl_image.h"

void boot_record_build(uint8_t record[BOOT_RECORD_BYTES], uint16_t length, uint16_t crc) {
  record[0] = BOOT_RECORD_MAGIC_0;
  record[1] = BOOT_RECORD_MAGIC_1;
  record[2] = BOOT_RECORD_MAGIC_2;
  record[3] = BOOT_RECORD_MAGIC_3;
  record[4] = (uint8_t)(length & 0xFFu);
  record[5] = (uint8_t)(length >> 8);
  record[6] = (uint8_t)(crc & 0xFFu);
  record[7] = (uint8_t)(crc >> 8);
}

bool boot_record_parse(const uint8_t record[BOOT_RECORD_BYTES], uint16_t max_length, uint16_t *length,
                       uint16_t *crc) {
  if (record[0] != BOOT_RECORD_MAGIC_0 || record[1] != BOOT_RECORD_MAGIC_1 || record[2] != BOOT_RECORD_MAGIC_2 ||
      record[3] != BOOT_RECORD_MAGIC_3) {
    return false;
  }
  *length = (uint16_t)(record[4] | ((uint16_t)record[5] << 8));
  *crc = (uint16_t)(record[6] | ((uint16_t)record[7] << 8));
  return *length != 0 && *length <= max_length;
}

uint16_t boot_crc_bytes(uint16_t crc, const uint8_t *bytes, uint16_t count) {
  while (count--) {
    crc = dxl_crc16_update(crc, *bytes++);
  }
  return crc;
}
