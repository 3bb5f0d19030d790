/* The framing rule (docs/policy.md "Framing and bus"), as one step per received byte: every
 * reader of the bus frames through it, so every reader cuts the same bytes into the same
 * packets whatever its timing. The servo's receive interrupt (firmware/hal), the link layer's
 * packet buffer (dxl_packet.h), the bus monitor of the simulator and the host tests all call
 * dxl_frame_step(); the receive interrupt's assembly (hal/uart_rx_fast.S) takes
 * some states without the call, for the figures docs/firmware.md names, and sim_differential
 * holds it to this function.
 *
 * The rule, byte by byte (a reader holds no byte it has passed, so there is nothing to rescan):
 *   - a header is two or more 0xFF, an ID other than 0xFF and a LENGTH; a byte that cannot
 *     start or continue one is garbage and the search goes on with the next byte;
 *   - LENGTH 0 or 1 is no packet (the search goes on with the next byte), except LENGTH 0 after
 *     the ID 0xFD: a Protocol 2.0 frame, whose ID, LEN_L and LEN_H follow, then LEN bytes, all
 *     passed over;
 *   - LENGTH 2..255: the packet is the LENGTH bytes that follow (instruction, parameters,
 *     checksum) whatever its ID and whatever its checksum turns out to be; the search starts
 *     again after its checksum;
 *   - a gap of more than DXL_PACKET_GAP_TIMEOUT_MS between two bytes ends whatever is under
 *     way: the caller measures time and calls dxl_frame_reset().
 *
 * Portable C, no clock, no buffer: the caller keeps what it wants of the bytes. */
#ifndef DXL_FRAME_H
#define DXL_FRAME_H

/* States (dxl_frame_t.state): what the next byte is. Plain numbers: the assembly of the
 * receive interrupt includes this header for them and for the field offsets. */
#define DXL_FRAME_SEARCH 0     /* a header's first 0xFF; anything else is garbage */
#define DXL_FRAME_SECOND_FF 1  /* its second 0xFF */
#define DXL_FRAME_ID 2         /* the ID, or a further 0xFF */
#define DXL_FRAME_LENGTH 3     /* the LENGTH */
#define DXL_FRAME_BODY 4       /* instruction, parameters, checksum: left of them to come */
#define DXL_FRAME_P2_ID 5      /* Protocol 2.0: its ID */
#define DXL_FRAME_P2_LENGTH_L 6 /* its length, low byte */
#define DXL_FRAME_P2_LENGTH_H 7 /* its length, high byte */
#define DXL_FRAME_P2_DATA 8    /* the bytes it counts: left + 256 x left_high of them to come */

/* Field offsets, for the assembly (checked against the struct in dxl_frame.c). */
#define DXL_FRAME_OFS_STATE 0
#define DXL_FRAME_OFS_LEFT 1
#define DXL_FRAME_OFS_ID 2
#define DXL_FRAME_OFS_LENGTH 3
#define DXL_FRAME_OFS_SUM 4
#define DXL_FRAME_OFS_LEFT_HIGH 5
#define DXL_FRAME_BYTES 6 /* sizeof (dxl_frame_t) */

/* What a byte was (dxl_frame_step's result). */
#define DXL_BYTE_GARBAGE 0  /* no packet: before a header, or the end of one that made none (the
                               bytes of that header are garbage too) */
#define DXL_BYTE_HEADER 1   /* a header's 0xFF or its ID: what it is, the next bytes tell */
#define DXL_BYTE_LENGTH 2   /* the LENGTH of a packet: frame->id, frame->length are set */
#define DXL_BYTE_BODY 3     /* its instruction or a parameter */
#define DXL_BYTE_CHECKSUM 4 /* its checksum, right: the packet is complete */
#define DXL_BYTE_CHECKSUM_BAD 5 /* its checksum, wrong: complete, to be rejected */
#define DXL_BYTE_PROTOCOL2 6 /* part of a Protocol 2.0 frame (its header's 0xFF and ID too) */

#ifndef __ASSEMBLER__

#include <stdbool.h>
#include <stdint.h>

#include "dxl_protocol.h"

typedef struct {
  uint8_t state;     /* DXL_FRAME_* */
  uint8_t left;      /* BODY: bytes still to come, the checksum last; P2_DATA: low byte */
  uint8_t id;        /* from the ID on */
  uint8_t length;    /* from the LENGTH on */
  uint8_t sum;       /* ID + LENGTH + the body bytes so far (mod 256) */
  uint8_t left_high; /* P2_DATA */
} dxl_frame_t;

/* The next byte starts a search: a frame that is all zeros is reset too. */
static inline void dxl_frame_reset(dxl_frame_t *frame) { frame->state = DXL_FRAME_SEARCH; }

/* True from a header's ID to its packet's checksum (states ID, LENGTH, BODY): a packet may end
 * within LENGTH + 2 bytes. Before the ID (SEARCH, SECOND_FF) and inside a Protocol 2.0 frame
 * the end of a 1.0 packet is at least four bytes away. */
static inline bool dxl_frame_in_packet(uint8_t state) {
  return (uint8_t)(state - DXL_FRAME_ID) <= (uint8_t)(DXL_FRAME_BODY - DXL_FRAME_ID);
}

/* Takes one byte; returns DXL_BYTE_*. */
uint8_t dxl_frame_step(dxl_frame_t *frame, uint8_t byte);

/* For a reader with a millisecond clock (16 bits, wrapping): true when a byte at now_ms comes
 * after a gap since the byte at last_ms, i.e. more than DXL_PACKET_GAP_TIMEOUT_MS later. */
static inline bool dxl_frame_gap(uint16_t last_ms, uint16_t now_ms) {
  return (uint16_t)(now_ms - last_ms) > DXL_PACKET_GAP_TIMEOUT_MS;
}

#endif /* __ASSEMBLER__ */
#endif
