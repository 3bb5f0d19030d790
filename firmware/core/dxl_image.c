/* The persistent settings in two slots. See dxl_image.h. */
#include "dxl_image.h"

#include <string.h>

#define CRC16_INITIAL 0xFFFFu
/* Serial number arithmetic on 8 bits: a difference below this is "ahead". */
#define SEQUENCE_HALF 128u

/* One byte's eight steps of polynomial 0x1021, MSB first, byte-wide (no loop, no table). */
uint16_t dxl_crc16_update(uint16_t crc, uint8_t byte) {
  crc = (uint16_t)((crc >> 8) | (crc << 8));
  crc ^= byte;
  crc ^= (uint16_t)((crc & 0xFFu) >> 4);
  crc ^= (uint16_t)(crc << 12);
  crc ^= (uint16_t)((crc & 0xFFu) << 5);
  return crc;
}

uint16_t dxl_image_slot_crc(const uint8_t slot[DXL_IMAGE_SLOT_BYTES]) {
  uint16_t crc = dxl_crc16_update(CRC16_INITIAL, DXL_IMAGE_FORMAT_VERSION);
  for (uint8_t i = 0; i < DXL_IMAGE_OFS_CRC; i++) {
    crc = dxl_crc16_update(crc, slot[i]);
  }
  return crc;
}

void dxl_image_slot_build(uint8_t slot[DXL_IMAGE_SLOT_BYTES], const uint8_t *eeprom_area, uint8_t sequence) {
  slot[DXL_IMAGE_OFS_SEQUENCE] = sequence;
  memcpy(&slot[DXL_IMAGE_OFS_TABLE], eeprom_area, CT_EEPROM_SIZE);
  const uint16_t crc = dxl_image_slot_crc(slot);
  slot[DXL_IMAGE_OFS_CRC] = (uint8_t)(crc & 0xFFu);
  slot[DXL_IMAGE_OFS_CRC + 1u] = (uint8_t)(crc >> 8);
}

bool dxl_image_slot_is_valid(const uint8_t slot[DXL_IMAGE_SLOT_BYTES]) {
  const uint16_t stored = (uint16_t)(slot[DXL_IMAGE_OFS_CRC] | ((uint16_t)slot[DXL_IMAGE_OFS_CRC + 1u] << 8));
  return stored == dxl_image_slot_crc(slot);
}

uint8_t dxl_image_newest_slot(const uint8_t image[DXL_IMAGE_BYTES]) {
  const uint8_t *const second = &image[DXL_IMAGE_SLOT_STRIDE];
  const bool first_valid = dxl_image_slot_is_valid(image);
  if (!dxl_image_slot_is_valid(second)) {
    return first_valid ? 0u : DXL_IMAGE_NO_SLOT;
  }
  const uint8_t ahead = (uint8_t)(second[DXL_IMAGE_OFS_SEQUENCE] - image[DXL_IMAGE_OFS_SEQUENCE]);
  return (!first_valid || (ahead != 0 && ahead < SEQUENCE_HALF)) ? 1u : 0u;
}

const uint8_t *dxl_image_settings(const uint8_t image[DXL_IMAGE_BYTES]) {
  const uint8_t slot = dxl_image_newest_slot(image);
  return slot == DXL_IMAGE_NO_SLOT ? NULL : &image[dxl_image_slot_offset(slot) + DXL_IMAGE_OFS_TABLE];
}

void dxl_image_build(uint8_t image[DXL_IMAGE_BYTES], const uint8_t *eeprom_area) {
  memset(image, 0xFF, DXL_IMAGE_BYTES);
  dxl_image_slot_build(image, eeprom_area, 0);
  dxl_image_slot_build(&image[DXL_IMAGE_SLOT_STRIDE], eeprom_area, 1);
}
