/* The application record. See boot_image.h. */
#include "boot_image.h"

#include "boot_layout.h"
#include "dxl_image.h"
#include "dxl_table.h"

/* The bootloader reads the settings at these offsets (boot_layout.h): the firmware's slots. */
_Static_assert(BOOT_EEPROM_IMAGE_BYTES == DXL_IMAGE_BYTES && BOOT_EEPROM_SLOT_STRIDE == DXL_IMAGE_SLOT_STRIDE &&
                   BOOT_EEPROM_SLOT_SEQUENCE == DXL_IMAGE_OFS_SEQUENCE &&
                   BOOT_EEPROM_SLOT_ID == DXL_IMAGE_OFS_TABLE + CT_ADDR_ID &&
                   BOOT_EEPROM_SLOT_BAUD == DXL_IMAGE_OFS_TABLE + CT_ADDR_BAUD_RATE,
               "boot_layout.h: the settings slots as firmware/core/dxl_image.h lays them out");

uint16_t boot_check_bytes(uint16_t check, const uint8_t *bytes, uint32_t count) {
  uint8_t sum1 = (uint8_t)check;
  uint8_t sum2 = (uint8_t)(check >> 8);
  while (count--) {
    sum1 = (uint8_t)(sum1 + *bytes++);
    sum2 = (uint8_t)(sum2 + sum1);
  }
  return (uint16_t)(sum1 | ((uint16_t)sum2 << 8));
}

void boot_record_build(uint8_t record[BOOT_RECORD_BYTES], uint32_t length, uint16_t check) {
  const uint16_t last = (uint16_t)(length - 1u);
  record[0] = (uint8_t)(last & 0xFFu);
  record[1] = (uint8_t)(last >> 8);
  record[2] = (uint8_t)(check & 0xFFu);
  record[3] = (uint8_t)(check >> 8);
}

bool boot_record_parse(const uint8_t record[BOOT_RECORD_BYTES], uint16_t boot_start, uint32_t *length,
                       uint16_t *check) {
  const uint16_t last = (uint16_t)(record[0] | ((uint16_t)record[1] << 8));
  *length = (uint32_t)last + 1u;
  *check = (uint16_t)(record[2] | ((uint16_t)record[3] << 8));
  return (last >> 8) < (boot_start >> 8);
}

bool boot_app_valid(const uint8_t *flash, uint32_t flash_bytes) {
  const uint16_t boot_start = boot_section_start(flash_bytes);
  uint32_t length;
  uint16_t check;
  return boot_record_parse(&flash[boot_record_address(boot_start)], boot_start, &length, &check) &&
         boot_check_bytes(0, flash, length) == check;
}
