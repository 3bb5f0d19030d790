/* A reference packet finder for the fuzzer: the framing rules of docs/policy.md "Framing and
 * bus" and "Resynchronisation" written the plain way, to be compared packet for packet with
 * firmware/core/dxl_packet.c (which is written for cycles, not for reading).
 *
 * It keeps every byte not yet consumed, each with a flag saying whether a gap of more than
 * DXL_PACKET_GAP_TIMEOUT_MS came before it, and looks at the front only:
 *   - a packet starts at the front when the bytes there are FF, FF, an ID other than FF and a
 *     LENGTH >= 2, and it is the 4 + LENGTH bytes from there when all of them are in with no
 *     gap before any of them but the first: its checksum ~(ID + LENGTH + body) decides between
 *     a packet (consumed whole) and a bad checksum (reported, then only the front byte goes);
 *   - while such a start is still short of bytes and no gap has ended the bytes held, wait;
 *   - a Protocol 2.0 frame: FF, FF, FD, 00 (LENGTH 0 after ID 0xFD), ID, LEN_L, LEN_H, all in
 *     with no gap before any but the first, is dropped with the LEN bytes that follow it as
 *     they come; a gap ends the frame, and the bytes after the gap are looked at as usual;
 *   - anything else: the front byte goes, and the front is looked at again.
 * A gap is a push or a poll at a time more than 100 ms (16-bit milliseconds, wrapping, as the
 * finder's contract says) after the last byte pushed. It holds up to REF_FINDER_CAPACITY bytes,
 * far more than the 259 a candidate can span: the harness takes the results after every
 * batch, as the firmware does. */
#ifndef REF_FINDER_H
#define REF_FINDER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "dxl_packet.h"

#define REF_FINDER_CAPACITY 4096u

typedef struct {
  uint8_t bytes[REF_FINDER_CAPACITY];
  bool gap_before[REF_FINDER_CAPACITY];
  size_t count;
  bool gap_at_end; /* a poll saw the gap after the last byte held */
  uint16_t last_byte_ms;
  unsigned skip; /* bytes of a Protocol 2.0 frame still to drop */
} ref_finder_t;

typedef struct {
  dxl_find_result_t result; /* DXL_FIND_PACKET or DXL_FIND_BAD_CHECKSUM */
  uint8_t id;
  uint8_t instruction;
  uint8_t param_count;
  uint8_t params[DXL_PACKET_MAX_BYTES];
  uint8_t checksum;
} ref_packet_t;

void ref_finder_init(ref_finder_t *ref);
/* Returns false when the reference is full (the caller pushed far more than the finder could
 * ever hold without taking its results). */
bool ref_finder_push(ref_finder_t *ref, uint8_t byte, uint16_t now_ms);
void ref_finder_poll(ref_finder_t *ref, uint16_t now_ms);
/* The next packet or bad checksum, DXL_FIND_NONE when it needs more bytes (or holds none). */
dxl_find_result_t ref_finder_next(ref_finder_t *ref, ref_packet_t *out);

#endif
