/* EEPROM image persistence. See nvm.h. */
#include "nvm.h"

#include <avr/eeprom.h>
#include <avr/io.h>
#include <stddef.h>

#include "dxl_image.h"

#define IMAGE_EEPROM_ADDR 0u

static uint8_t image[DXL_IMAGE_BYTES];
/* Image bytes still to compare, from the end: the next offset is DXL_IMAGE_BYTES - this.
 * Zero (all done) at reset, so the firmware has no initialised data (no copy loop). */
static uint8_t bytes_left;

/* EE_READY (tiny_isr.S) only clears EERIE: while enabled it is raised for as long as the
 * EEPROM is ready; its job is to wake the main loop after a write. */

const uint8_t *nvm_load(void) {
  /* Byte by byte: eeprom_read_byte() is linked anyway (nvm_service), eeprom_read_block() would
   * add 32 B of flash. */
  for (uint8_t offset = 0; offset < DXL_IMAGE_BYTES; offset++) {
    image[offset] = eeprom_read_byte((const uint8_t *)(uintptr_t)(IMAGE_EEPROM_ADDR + offset));
  }
  return dxl_image_is_valid(image) ? &image[DXL_IMAGE_OFS_TABLE] : NULL;
}

void nvm_persist(const uint8_t *eeprom_area) {
  dxl_image_build(image, eeprom_area);
  bytes_left = DXL_IMAGE_BYTES;
}

bool nvm_busy(void) { return bytes_left != 0 || !eeprom_is_ready(); }

bool nvm_work_ready(void) { return bytes_left != 0 && eeprom_is_ready(); }

void nvm_service(void) {
  while (nvm_work_ready()) {
    const uint8_t offset = (uint8_t)(DXL_IMAGE_BYTES - bytes_left--);
    uint8_t *const addr = (uint8_t *)(uintptr_t)(IMAGE_EEPROM_ADDR + offset);
    if (eeprom_read_byte(addr) != image[offset]) {
      eeprom_write_byte(addr, image[offset]);
      EECR |= _BV(EERIE);
      return;
    }
  }
}
