#include "dxl_image.h"

#include <string.h>

#define CRC8_POLYNOMIAL 0x07u

uint8_t dxl_crc8(const uint8_t *data, uint8_t count) {
  uint8_t crc = 0;
  for (uint8_t i = 0; i < count; i++) {
    crc ^= data[i];
    for (uint8_t bit = 0; bit < 8; bit++) {
      crc = (crc & 0x80u) ? (uint8_t)((crc << 1) ^ CRC8_POLYNOMIAL) : (uint8_t)(crc << 1);
    }
  }
  return crc;
}

void dxl_image_build(uint8_t image[DXL_IMAGE_BYTES], const uint8_t *eeprom_area) {
  image[DXL_IMAGE_OFS_VERSION] = DXL_IMAGE_FORMAT_VERSION;
  memcpy(&image[DXL_IMAGE_OFS_TABLE], eeprom_area, CT_EEPROM_SIZE);
  image[DXL_IMAGE_OFS_CRC] = dxl_crc8(image, DXL_IMAGE_OFS_CRC);
}

bool dxl_image_is_valid(const uint8_t image[DXL_IMAGE_BYTES]) {
  return image[DXL_IMAGE_OFS_VERSION] == DXL_IMAGE_FORMAT_VERSION &&
         image[DXL_IMAGE_OFS_CRC] == dxl_crc8(image, DXL_IMAGE_OFS_CRC);
}
