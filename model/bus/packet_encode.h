/* SPDX-License-Identifier: MIT */
/* Dynamixel Protocol 1.0 packets, encoded from the manual and not by the firmware under test:
 * FF FF ID LENGTH code params... checksum, LENGTH = params + 2, checksum
 * ~(ID + LENGTH + code + params) & 0xFF. code is the instruction of an instruction packet or
 * the error byte of a status packet. The one encoder of the tools (ax12-bench, ax12-lab) and
 * the tests (test/core, test/sim); pure C (MIT, as the rest of model/bus). */
#ifndef MODEL_PACKET_ENCODE_H
#define MODEL_PACKET_ENCODE_H

#include <stddef.h>
#include <stdint.h>

/* Bytes a packet adds to its parameters: FF FF ID LENGTH code ... checksum. */
#define PACKET_OVERHEAD 6u
/* The most parameters LENGTH can announce (255 - 2). */
#define PACKET_MAX_PARAMS 253u

/* The checksum of the bytes from ID to the last parameter (count of them). */
uint8_t packet_checksum(const uint8_t *id_to_last_param, size_t count);

/* Writes the packet to out (count + PACKET_OVERHEAD bytes) and returns its size. params may be
 * NULL when count is 0; count <= PACKET_MAX_PARAMS. */
size_t packet_encode(uint8_t *out, uint8_t id, uint8_t code, const uint8_t *params, size_t count);

/* Bytes as hex for messages ("FF FF 01 ..." or "(none)"), cut to fit text_len; returns text. */
const char *packet_hex(const uint8_t *bytes, size_t count, char *text, size_t text_len);

#endif
