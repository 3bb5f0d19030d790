/* The bootloader's packets (docs/bootloader.md "Packets"): Protocol 1.0 requests to the
 * servo's ID, status packets back. Constants only: included by the bootloader's assembly and
 * by the tests. */
#ifndef BOOT_PROTOCOL_H
#define BOOT_PROTOCOL_H

/* What INFO reports first: the layout of docs/bootloader.md (512 B boot section, the record
 * in the last 4 B below it). */
#define BOOT_VERSION 2

#define BOOT_INST_PING 0x01
/* The application's way in (docs/bootloader.md "Entering from the application"); answered
 * like a PING here, whatever its parameters. */
#define BOOT_INST_ENTER 0x0A
#define BOOT_INST_INFO 0x20
#define BOOT_INST_PAGE 0x22
#define BOOT_INST_READ 0x24
#define BOOT_INST_GO 0x25

#define BOOT_ERROR_INSTRUCTION 0x40 /* unknown instruction; PAGE or READ of the wrong length */
#define BOOT_ERROR_PROGRAM 0x20     /* the page does not read back as sent */
#define BOOT_ERROR_RANGE 0x08       /* not a page of the application area */

/* INFO's parameters: BOOT_VERSION and the MCU's three signature bytes. */
#define BOOT_INFO_BYTES 4
/* PAGE's parameters: the page's address (16 bits, little-endian), then its bytes; its answer
 * carries the first two back. */
#define BOOT_PAGE_HEAD_BYTES 2

#endif
