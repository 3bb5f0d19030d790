/* The persistent image of the EEPROM area (docs/hardware.md "EEPROM image"):
 *   [0] format version, [1..24] control table 0..23, [25] CRC-8 of bytes 0..24.
 * Shared by the firmware (which stores it at EEPROM address 0) and the simulator host (which
 * seeds and inspects state files), so both agree byte for byte. */
#ifndef DXL_IMAGE_H
#define DXL_IMAGE_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_table.h"

#define DXL_IMAGE_FORMAT_VERSION 1u
#define DXL_IMAGE_OFS_VERSION 0u
#define DXL_IMAGE_OFS_TABLE 1u
#define DXL_IMAGE_OFS_CRC (1u + CT_EEPROM_SIZE)
#define DXL_IMAGE_BYTES (2u + CT_EEPROM_SIZE)

/* CRC-8, polynomial x^8 + x^2 + x + 1 (0x07), initial value 0, no reflection. */
uint8_t dxl_crc8(const uint8_t *data, uint8_t count);

/* Fills image from the EEPROM area of a control table. */
void dxl_image_build(uint8_t image[DXL_IMAGE_BYTES], const uint8_t *eeprom_area);

/* True when image has this format's version and a matching CRC. */
bool dxl_image_is_valid(const uint8_t image[DXL_IMAGE_BYTES]);

#endif
