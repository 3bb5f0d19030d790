/* Instruction packets for the tests, built here and not by the core under test: FF FF ID
 * LENGTH instruction params... checksum, with the checksum computed as the manual defines it
 * (~(ID + LENGTH + instruction + params) & 0xFF). */
#ifndef TEST_PACKET_BUILD_H
#define TEST_PACKET_BUILD_H

#include <stddef.h>
#include <stdint.h>

/* Writes the packet to out (count + 6 bytes) and returns its size. params may be NULL when
 * count is 0. */
size_t packet_build(uint8_t *out, uint8_t id, uint8_t instruction, const uint8_t *params, size_t count);

/* Bytes as hex for failure messages ("FF FF 01 ..." or "(none)"), cut to fit text_len;
 * returns text. */
const char *packet_hex(const uint8_t *bytes, size_t count, char *text, size_t text_len);

#endif
