/* A reference packet finder for the tests (the fuzzer, the core's bad-input streams): the framing rule of docs/policy.md "Framing and
 * bus" written the plain way, over the bytes held, to be compared packet for packet with the
 * framing step every reader runs (firmware/core/dxl_frame.c, one byte at a time, holding
 * nothing it has passed).
 *
 * It keeps the bytes not yet consumed and looks at the front only:
 *   - a byte other than 0xFF, or an 0xFF not followed by another, is garbage: it goes;
 *   - FF FF and a further 0xFF: the further one goes (a header may have any number of them);
 *   - FF FF ID LENGTH with LENGTH >= 2: a packet, the 4 + LENGTH bytes from there once all are
 *     in; its checksum ~(ID + LENGTH + body) tells a packet from a bad checksum; either way
 *     all of them go;
 *   - FF FF FD 00 ID LEN_L LEN_H: a Protocol 2.0 frame: these go, and the LEN bytes after them
 *     as they come;
 *   - FF FF ID LENGTH with LENGTH 0 or 1 (but a 2.0 header): no packet, the four go;
 *   - a gap (a push or a poll more than 100 ms after the last byte pushed, on a 16-bit
 *     millisecond clock) ends what is under way (a packet's bytes so far, a 2.0 frame): the
 *     next byte starts afresh.
 * It frames each packet as its last byte comes, and queues up to REF_FINDER_QUEUE of them for
 * ref_finder_next(); it holds up to REF_FINDER_CAPACITY bytes, more than a packet can span. */
#ifndef REF_FINDER_H
#define REF_FINDER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "dxl_packet.h"

#define REF_FINDER_CAPACITY 4096u
#define REF_FINDER_QUEUE 64u

typedef struct {
  dxl_find_result_t result; /* DXL_FIND_PACKET or DXL_FIND_BAD_CHECKSUM */
  uint64_t start; /* index of its first byte (FF FF right before the ID) in everything pushed */
  uint8_t id;
  uint8_t instruction;
  uint8_t param_count;
  uint8_t params[DXL_PACKET_MAX_BYTES];
  uint8_t checksum;
} ref_packet_t;

typedef struct {
  uint8_t bytes[REF_FINDER_CAPACITY];
  size_t count;
  bool any_byte;
  uint16_t last_byte_ms;
  unsigned skip; /* bytes of a Protocol 2.0 frame still to drop */
  uint64_t consumed; /* bytes pushed and gone, the front's index in everything pushed */
  ref_packet_t found[REF_FINDER_QUEUE]; /* framed, not yet taken: found_count from found_first */
  unsigned found_first;
  unsigned found_count;
} ref_finder_t;

void ref_finder_init(ref_finder_t *ref);
/* Returns false when the reference is full (the caller pushed far more than a packet spans, or
 * left REF_FINDER_QUEUE packets untaken). */
bool ref_finder_push(ref_finder_t *ref, uint8_t byte, uint16_t now_ms);
void ref_finder_poll(ref_finder_t *ref, uint16_t now_ms);
/* The oldest packet or bad checksum framed and not yet taken; DXL_FIND_NONE when none is. */
dxl_find_result_t ref_finder_next(ref_finder_t *ref, ref_packet_t *out);

#endif
