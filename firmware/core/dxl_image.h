/* The persistent settings (docs/hardware.md "EEPROM image"): the EEPROM area of the control
 * table (addresses 0..23) in two slots that are written in turn, so that a power cut at any
 * moment of a write leaves the last complete settings readable.
 *
 * One slot, DXL_IMAGE_SLOT_BYTES bytes at EEPROM address slot x DXL_IMAGE_SLOT_STRIDE:
 *   [0]       sequence number (8 bits, wrapping): the slot written last has the higher one
 *   [1..24]   control table 0..23
 *   [25..26]  CRC-16 (little-endian) over the format version and bytes 0..24
 * Contract of a write (the firmware's nvm.c): it goes to the slot that does not hold the
 * settings in use, bytes 1..26 first and the sequence number last, so until the last byte
 * is in, that slot fails its CRC or carries an older sequence number than the other, and the
 * other still boots. A torn byte reads back as anything: the CRC-16 rejects a slot with any
 * mix of two contents except with probability 2^-16, and even then its older sequence number
 * loses to the complete slot.
 *
 * Shared by the firmware and the simulator host (which seeds and inspects state files), so
 * both agree byte for byte. Portable C. */
#ifndef DXL_IMAGE_H
#define DXL_IMAGE_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_table.h"

/* Part of every slot's CRC: an image of another format never passes as this one. */
#define DXL_IMAGE_FORMAT_VERSION 2u
#define DXL_IMAGE_OFS_SEQUENCE 0u
#define DXL_IMAGE_OFS_TABLE 1u
#define DXL_IMAGE_OFS_CRC (1u + CT_EEPROM_SIZE)
#define DXL_IMAGE_SLOT_BYTES (3u + CT_EEPROM_SIZE)
#define DXL_IMAGE_SLOT_STRIDE 32u
#define DXL_IMAGE_SLOTS 2u
/* EEPROM bytes the image spans (from address 0). */
#define DXL_IMAGE_BYTES (DXL_IMAGE_SLOT_STRIDE + DXL_IMAGE_SLOT_BYTES)
#define DXL_IMAGE_NO_SLOT 0xFFu

/* One step of CRC-16/CCITT (polynomial 0x1021, MSB first). Starting from 0xFFFF over
 * "123456789" it gives 0x29B1 (CRC-16/CCITT-FALSE). */
uint16_t dxl_crc16_update(uint16_t crc, uint8_t byte);

/* The CRC a slot must carry: CRC-16 from 0xFFFF over the format version, then bytes
 * [0..DXL_IMAGE_OFS_CRC) of the slot. */
uint16_t dxl_image_slot_crc(const uint8_t slot[DXL_IMAGE_SLOT_BYTES]);

/* Fills a slot from the EEPROM area of a control table, with this sequence number. */
void dxl_image_slot_build(uint8_t slot[DXL_IMAGE_SLOT_BYTES], const uint8_t *eeprom_area, uint8_t sequence);

/* True when the slot's CRC matches (this format). */
bool dxl_image_slot_is_valid(const uint8_t slot[DXL_IMAGE_SLOT_BYTES]);

/* Which slot of an EEPROM image (DXL_IMAGE_BYTES from address 0) holds the settings to boot:
 * the valid one, or of two valid ones the one whose sequence number is ahead (serial number
 * arithmetic: b - a in 1..127 means b is newer); DXL_IMAGE_NO_SLOT when neither is valid. */
uint8_t dxl_image_newest_slot(const uint8_t image[DXL_IMAGE_BYTES]);

/* The EEPROM area (CT_EEPROM_SIZE bytes) in the newest valid slot of image, NULL when
 * neither slot is valid. */
const uint8_t *dxl_image_settings(const uint8_t image[DXL_IMAGE_BYTES]);

/* Byte offset of a slot in the image. */
static inline uint8_t dxl_image_slot_offset(uint8_t slot) { return (uint8_t)(slot * DXL_IMAGE_SLOT_STRIDE); }

/* The order in which a slot's bytes are written: step 0..DXL_IMAGE_SLOT_BYTES-1 writes this
 * offset (1, 2, ..., 26, then 0: the sequence number last). */
static inline uint8_t dxl_image_write_offset(uint8_t step) {
  return (uint8_t)(step + 1u == DXL_IMAGE_SLOT_BYTES ? 0u : step + 1u);
}

/* Fills image (DXL_IMAGE_BYTES) as a blank EEPROM (0xFF) holding eeprom_area in both slots,
 * slot 1 (sequence number 1) the newest: a new servo's first settings (the emulator's seeds,
 * the tests), whose next write then stores only the bytes it changes (into slot 0). */
void dxl_image_build(uint8_t image[DXL_IMAGE_BYTES], const uint8_t *eeprom_area);

#endif
