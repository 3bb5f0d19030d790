/* The part the bootloader is built for, as compile-time constants: on the AVR from avr/io.h,
 * on the host (the tests) from the build's -D definitions of BOOT_FLASH_BYTES, BOOT_PAGE_BYTES
 * and BOOT_SIGNATURE_0..2. Constants, not a runtime description: they make the bootloader
 * several hundred bytes smaller, which its 2 KB need. */
#ifndef BOOT_PART_H
#define BOOT_PART_H

#include "boot_image.h"

#ifdef __AVR__
#include <avr/io.h>
#define BOOT_FLASH_BYTES (FLASHEND + 1ul)
#define BOOT_PAGE_BYTES SPM_PAGESIZE
#define BOOT_SIGNATURE_0 SIGNATURE_0
#define BOOT_SIGNATURE_1 SIGNATURE_1
#define BOOT_SIGNATURE_2 SIGNATURE_2
#endif

#if !defined(BOOT_FLASH_BYTES) || !defined(BOOT_PAGE_BYTES) || !defined(BOOT_SIGNATURE_2)
#error "boot_part.h: BOOT_FLASH_BYTES, BOOT_PAGE_BYTES and BOOT_SIGNATURE_0..2 must be defined"
#endif

/* The boot section's start: the end of the application area. */
#define BOOT_START ((uint16_t)(BOOT_FLASH_BYTES - BOOT_SECTION_BYTES))
/* The application record's page, the last of the application area. */
#define BOOT_RECORD_ADDRESS ((uint16_t)(BOOT_START - BOOT_PAGE_BYTES))

#endif
