/* The application image as the bootloader keeps it (docs/bootloader.md "Flash layout"): the
 * image from address 0, and the application record in the last BOOT_RECORD_BYTES of the
 * application area, just below the boot section (the top BOOT_SECTION_BYTES of flash).
 *
 * Record, little-endian: the address of the image's last byte (16 bits: the image is bytes 0
 * .. last), then the image's check value (16 bits): Fletcher-16 modulo 256 over those bytes,
 * sum1 (low byte) and sum2 (high byte), both from 0 (boot_check_bytes()). An erased record
 * (FF FF FF FF) names a last byte inside the boot section: not valid.
 *
 * Shared by the bootloader (assembly: the constants only), its tests and the emulator (which
 * writes the record of the application ELF it loads, as the merged HEX of a board carries
 * it). Portable C. */
#ifndef BOOT_IMAGE_H
#define BOOT_IMAGE_H

/* The boot section: the top 512 B of flash on both parts (ATmega88: 0x1E00, ATmega328P:
 * 0x7E00; BOOTSZ in docs/hardware.md "Fuses"). */
#define BOOT_SECTION_BYTES 512
#define BOOT_RECORD_BYTES 4

#ifndef __ASSEMBLER__
#include <stdbool.h>
#include <stdint.h>

/* The boot section's first byte on a part with flash_bytes of flash. */
static inline uint16_t boot_section_start(uint32_t flash_bytes) {
  return (uint16_t)(flash_bytes - BOOT_SECTION_BYTES);
}

/* Where the record lives: the last BOOT_RECORD_BYTES below the boot section. */
static inline uint16_t boot_record_address(uint16_t boot_start) {
  return (uint16_t)(boot_start - BOOT_RECORD_BYTES);
}

/* The check value of count bytes, continued from check (start with 0). */
uint16_t boot_check_bytes(uint16_t check, const uint8_t *bytes, uint32_t count);

/* Fills record for an image of length bytes (1 .. 65536) with this check value. */
void boot_record_build(uint8_t record[BOOT_RECORD_BYTES], uint32_t length, uint16_t check);

/* True when the record names an image that ends below the boot section (its last address
 * below boot_start, a multiple of 256 on both parts): *length and *check then hold what it
 * says (the check value is still to be compared with the flash). */
bool boot_record_parse(const uint8_t record[BOOT_RECORD_BYTES], uint16_t boot_start, uint32_t *length,
                       uint16_t *check);

/* True when the application in flash (flash_bytes of it, boot section included) is valid:
 * what the bootloader decides at reset. */
bool boot_app_valid(const uint8_t *flash, uint32_t flash_bytes);
#endif

#endif
