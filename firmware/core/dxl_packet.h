/* The packet finder: Protocol 1.0 packets out of a byte stream, framed by the one rule of
 * dxl_frame.h (docs/policy.md "Framing and bus") and kept whole for the caller.
 *
 * It runs the framing step on each byte it takes and holds the packet being framed, header
 * written as FF FF ID LENGTH, then the instruction, parameters and checksum as they come: a
 * returned packet is the first 4 + LENGTH held bytes. Packets for any ID, and other servos'
 * status packets, are framed the same way; choosing what to act on is the caller's business.
 * It holds no byte it has framed past, so it never rescans; a gap is the caller's to measure
 * (dxl_finder_gap).
 *
 * Use, one byte at a time: dxl_finder_push(). In batches (the link layer, from the receive
 * ring): dxl_finder_slot() says where the next bytes go and how many it takes at most (never
 * past the end of a packet, so one batch completes at most one packet, with its last byte);
 * the caller writes up to that many there and reports them with dxl_finder_pushed(). A
 * packet's body is taken in one tight loop, a header byte by byte.
 *
 * A returned packet's params point into the finder and stay valid until the next slot, push or
 * gap. */
#ifndef DXL_PACKET_H
#define DXL_PACKET_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_frame.h"

#define DXL_PACKET_MAX_BYTES 259u /* FF FF ID LENGTH + LENGTH (<= 255) bytes */
#define DXL_PACKET_MIN_LENGTH 2u  /* instruction + checksum */
#define DXL_PACKET_HEADER_BYTES 4u /* FF FF ID LENGTH, as the finder holds them */

typedef struct {
  uint8_t id;
  uint8_t instruction; /* the error byte, when this is another servo's status packet */
  uint8_t param_count; /* LENGTH - 2 */
  const uint8_t *params;
  uint8_t checksum; /* as received */
} dxl_packet_t;

typedef enum {
  DXL_FIND_NONE = 0,     /* nothing (more) until further bytes arrive */
  DXL_FIND_PACKET,       /* a packet with a good checksum */
  DXL_FIND_BAD_CHECKSUM, /* a framed packet whose checksum is wrong; its fields are reported */
} dxl_find_result_t;

typedef struct {
  dxl_frame_t frame;
  uint16_t fill; /* bytes held: the packet framed so far, or the last one returned */
  uint8_t bytes[DXL_PACKET_MAX_BYTES];
} dxl_finder_t;

/* Empties the finder: all zeros (a finder zeroed with its container is initialised). */
void dxl_finder_init(dxl_finder_t *finder);

/* One byte: DXL_FIND_NONE, or the packet it completed in *packet. */
dxl_find_result_t dxl_finder_push(dxl_finder_t *finder, uint8_t byte, dxl_packet_t *packet);

/* Batch push, the same as dxl_finder_push() for each byte: slot returns where the next bytes
 * go and sets *count to how many the finder takes (at least 1); the caller writes up to that
 * many there and reports them with dxl_finder_pushed() (0 is allowed), nothing else in
 * between. */
uint8_t *dxl_finder_slot(dxl_finder_t *finder, uint16_t *count);
dxl_find_result_t dxl_finder_pushed(dxl_finder_t *finder, uint16_t count, dxl_packet_t *packet);

/* A gap of more than DXL_PACKET_GAP_TIMEOUT_MS since the last byte: the packet or header under
 * way is dropped and the next byte starts a search. */
void dxl_finder_gap(dxl_finder_t *finder);

/* True when no packet, header or Protocol 2.0 frame is under way: the next byte starts a
 * search. */
static inline bool dxl_finder_idle(const dxl_finder_t *finder) { return finder->frame.state == DXL_FRAME_SEARCH; }

/* Bytes of the packet under way still to come, its checksum included (0 when none is). */
static inline uint8_t dxl_finder_left(const dxl_finder_t *finder) {
  return finder->frame.state == DXL_FRAME_BODY ? finder->frame.left : 0u;
}

/* The packet under way as held so far: valid once its instruction is in; its checksum field
 * only once that is in. Lets the caller prepare a reply while the last bytes are still on the
 * wire, when it knows from elsewhere (the firmware's receive interrupt) that it will want it. */
void dxl_finder_candidate(const dxl_finder_t *finder, dxl_packet_t *packet);

/* The bytes held (the packet first): a returned packet is the first 4 + LENGTH of them until
 * the next slot, push or gap. */
static inline const uint8_t *dxl_finder_held(const dxl_finder_t *finder) { return finder->bytes; }

/* The Protocol 1.0 checksum of ID, LENGTH and the body bytes. */
uint8_t dxl_checksum(const uint8_t *id_length_body, uint16_t count);

#endif
