/* The bootloader's side of an update (docs/bootloader.md "Packets"): a packet to this servo in,
 * its status packet out. Portable C: the part from boot_part.h, the flash behind boot_port.h,
 * no clock, no UART.
 *
 * The application area is [0, BOOT_START); its last page holds the application record
 * (boot_image.h). The record page is erased by BEGIN and written by END only once the CRC of
 * the whole image in flash matched, so a cut anywhere between leaves an application that is
 * not valid (boot_app_valid() false): the bootloader stays and takes a new update. */
#ifndef BOOT_PROTOCOL_H
#define BOOT_PROTOCOL_H

#include <stdbool.h>
#include <stdint.h>

#include "boot_part.h"
#include "dxl_packet.h"

#define BOOT_VERSION 1u

#define BOOT_INST_PING 0x01u
#define BOOT_INST_INFO 0x20u
#define BOOT_INST_BEGIN 0x21u
#define BOOT_INST_PAGE 0x22u
#define BOOT_INST_END 0x23u
#define BOOT_INST_READ 0x24u
#define BOOT_INST_GO 0x25u
/* The application's way in (docs/bootloader.md "Entering from the application"), with the
 * parameters "BOOT"; answered like a PING in the bootloader. */
#define BOOT_INST_ENTER 0x0Au
#define BOOT_ENTER_KEY_0 0x42u
#define BOOT_ENTER_KEY_1 0x4Fu
#define BOOT_ENTER_KEY_2 0x4Fu
#define BOOT_ENTER_KEY_3 0x54u

#define BOOT_ERROR_INSTRUCTION 0x40u
#define BOOT_ERROR_PROGRAM 0x20u /* a page did not read back as written */
#define BOOT_ERROR_CRC 0x10u
#define BOOT_ERROR_RANGE 0x08u

/* INFO's state byte. */
#define BOOT_STATE_APP_VALID 0x01u
#define BOOT_STATE_BY_REQUEST 0x02u
#define BOOT_STATE_BY_HASH 0x04u

#define BOOT_INFO_BYTES 13u
/* The longest status packet: READ's, a page. */
#define BOOT_REPLY_MAX_BYTES (6u + BOOT_PAGE_BYTES)

typedef struct {
  uint8_t id;
  uint8_t entered_by; /* BOOT_STATE_BY_* */
  bool begun;         /* BEGIN taken: PAGE and END allowed */
  bool start_app;     /* GO answered with a valid application: start it after the reply */
  uint16_t image_length;
  uint16_t image_crc;
} boot_t;

void boot_init(boot_t *boot, uint8_t id, uint8_t entered_by);

/* True when the record is whole and the CRC of the image in flash matches it. */
bool boot_app_valid(void);

/* Handles a packet with a good checksum. Writes the status packet to reply and returns its
 * length; 0 (nothing to send) for a packet to another ID or broadcast. */
uint8_t boot_handle(boot_t *boot, const dxl_packet_t *packet, uint8_t reply[BOOT_REPLY_MAX_BYTES]);

#endif
