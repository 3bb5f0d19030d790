/* The application image as the bootloader keeps it (docs/bootloader.md "Flash layout"): the
 * image from address 0, and the application record at the start of the last page below the
 * boot section, which says how long the image is and what its CRC is.
 *
 * Record: "AXAP", image length (16 bits, LE), CRC-16/CCITT-FALSE of image bytes 0..length-1
 * (16 bits, LE; dxl_crc16_update from 0xFFFF); the rest of its page 0xFF.
 *
 * Shared by the bootloader, its host tests and the emulator (which writes the record of the
 * application ELF it loads, as the merged HEX of a board carries it). Portable C. */
#ifndef BOOT_IMAGE_H
#define BOOT_IMAGE_H

#include <stdbool.h>
#include <stdint.h>

#define BOOT_RECORD_MAGIC_0 0x41u /* 'A' */
#define BOOT_RECORD_MAGIC_1 0x58u /* 'X' */
#define BOOT_RECORD_MAGIC_2 0x41u /* 'A' */
#define BOOT_RECORD_MAGIC_3 0x50u /* 'P' */
#define BOOT_RECORD_BYTES 8u
#define BOOT_CRC_INITIAL 0xFFFFu

/* The boot section is the top 2 KB of flash on every part (ATmega88: 0x1800, ATmega328P:
 * 0x7800). */
#define BOOT_SECTION_BYTES 2048u

/* Where a part's record lives: the last page below the boot section. */
static inline uint16_t boot_record_address(uint16_t boot_start, uint16_t page_bytes) {
  return (uint16_t)(boot_start - page_bytes);
}

/* Fills record (BOOT_RECORD_BYTES) for an image of length bytes with this CRC. */
void boot_record_build(uint8_t record[BOOT_RECORD_BYTES], uint16_t length, uint16_t crc);

/* True when record has the magic and a length of 1..max_length; *length and *crc then hold
 * what it says (the CRC is still to be checked against the flash). */
bool boot_record_parse(const uint8_t record[BOOT_RECORD_BYTES], uint16_t max_length, uint16_t *length,
                       uint16_t *crc);

/* CRC of count bytes continuing from crc (start with BOOT_CRC_INITIAL). */
uint16_t boot_crc_bytes(uint16_t crc, const uint8_t *bytes, uint16_t count);

#endif
