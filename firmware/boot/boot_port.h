/* What the bootloader's protocol (boot_protocol.h) needs of the part: reading and programming
 * flash. The AVR's boot_main.c implements it with LPM and SPM; the host tests with an array.
 * Addresses are byte addresses. */
#ifndef BOOT_PORT_H
#define BOOT_PORT_H

#include <stdint.h>

/* The flash byte at address. */
uint8_t boot_port_flash_byte(uint16_t address);

/* Erases the page at page_address (page-aligned) and programs it with page_bytes bytes (the
 * part's page size); returns when the flash reads back as programmed or failed to. */
void boot_port_flash_program(uint16_t page_address, const uint8_t *bytes);

#endif
