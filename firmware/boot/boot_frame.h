/* The bootloader's packet framer: Protocol 1.0 packets from a byte stream, one byte at a time.
 *
 * The bootloader cannot afford the core's finder (firmware/core/dxl_packet.h: about 700 B of
 * its 2048 on the ATmega328P, against about 150 B for this), so it frames by the same header
 * and LENGTH rules in a simpler way: two or more 0xFF, ID (0..0xFE), LENGTH (2..
 * BOOT_FRAME_MAX_LENGTH), LENGTH-1 bytes, checksum; a LENGTH out of range, a wrong checksum
 * or a gap of more than DXL_PACKET_GAP_TIMEOUT_MS between two bytes drops the candidate and
 * the search starts again at the next byte. Unlike the core's finder it does not rescan a
 * rejected candidate's bytes for a packet starting inside them: the flasher (scripts/ax12
 * flash) retries a packet that got no answer. Portable C. */
#ifndef BOOT_FRAME_H
#define BOOT_FRAME_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_packet.h"

/* The longest LENGTH taken: a PAGE of the largest page (128 B), its 4 parameters, the
 * instruction and the checksum. */
#define BOOT_FRAME_MAX_LENGTH 134u

typedef struct {
  uint8_t state;  /* what the next byte is (boot_frame.c) */
  uint8_t id;
  uint8_t length; /* LENGTH of the candidate */
  uint8_t fill;   /* body bytes (instruction, parameters) held */
  uint8_t sum;    /* ID + LENGTH + body so far */
  uint16_t last_byte_ms;
  uint8_t body[BOOT_FRAME_MAX_LENGTH - 1u];
} boot_frame_t;

void boot_frame_init(boot_frame_t *frame);

/* Takes one byte that arrived at now_ms. True when it completed a packet with a good checksum,
 * described in *packet (params point into frame, valid until the next push). */
bool boot_frame_push(boot_frame_t *frame, uint8_t byte, uint16_t now_ms, dxl_packet_t *packet);

#endif
