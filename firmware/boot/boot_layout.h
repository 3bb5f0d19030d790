/* Where the bootloader keeps things: the settings it reads from the EEPROM, its packet
 * buffer in RAM and the registers its assembly files share. Constants only (the register
 * names in assembly only). */
#ifndef BOOT_LAYOUT_H
#define BOOT_LAYOUT_H

/* The settings (firmware/core/dxl_image.h, checked in boot_image.c): two slots of a sequence
 * number and the control table's EEPROM area; the bootloader reads the ID and the Baud Rate
 * of the slot written last. */
#define BOOT_EEPROM_IMAGE_BYTES 59
#define BOOT_EEPROM_SLOT_STRIDE 32
#define BOOT_EEPROM_SLOT_SEQUENCE 0
#define BOOT_EEPROM_SLOT_ID 4
#define BOOT_EEPROM_SLOT_BAUD 5
/* Without settings: the factory ID and Baud Rate (1 Mbps). */
#define BOOT_DEFAULT_ID 1
#define BOOT_DEFAULT_BAUD 1
/* The stock recovery trigger: '#' at Baud Rate register 34 (57 142 bps, "57 600"). */
#define BOOT_HASH_BYTE 0x23
#define BOOT_HASH_COUNT 2
#define BOOT_HASH_BAUD 34

/* The packet buffer at RAMSTART (a multiple of 256 on both parts, so its offsets are the low
 * byte of X): a request as it arrives from its ID on, and its status packet in the same
 * place. */
#define BOOT_BUF_HEADER 0 /* FF FF, written once */
#define BOOT_BUF_ID 2
#define BOOT_BUF_LENGTH 3
#define BOOT_BUF_INSTRUCTION 4 /* the error byte in the status packet */
#define BOOT_BUF_PARAMS 5

#ifdef __ASSEMBLER__
/* Registers kept across the whole bootloader (r1 is zero, as in C). */
#define ID r2          /* the servo's ID */
#define BAUD r4        /* the Baud Rate register of the settings */
#define FRAME_STATE r16
#define FRAME_SUM r17
#define FRAME_LEFT r18 /* framing: body bytes still to come */
#define ERROR r20      /* the status packet's error byte */
#define COUNT r21      /* the status packet's parameter count */
#define TXC_CLEAR r22  /* UCSR0A with TXC0 written 1 (clears it) and U2X0 kept */
/* Y = RAMSTART, the buffer, throughout. X points into its first 256 B (XH = YH: the
 * instructions set XL only); the framing step writes through Z, as a packet of up to 257 B
 * runs past them. */
#endif

#endif
