#include "dxl_frame.h"

#include <stddef.h>

#include "dxl_protocol.h"

_Static_assert(offsetof(dxl_frame_t, state) == DXL_FRAME_OFS_STATE && offsetof(dxl_frame_t, id) == DXL_FRAME_OFS_ID &&
                   offsetof(dxl_frame_t, length) == DXL_FRAME_OFS_LENGTH &&
                   offsetof(dxl_frame_t, left) == DXL_FRAME_OFS_LEFT && offsetof(dxl_frame_t, sum) == DXL_FRAME_OFS_SUM &&
                   offsetof(dxl_frame_t, left_high) == DXL_FRAME_OFS_LEFT_HIGH &&
                   sizeof(dxl_frame_t) == DXL_FRAME_BYTES,
               "dxl_frame.h's offsets are the struct's");

/* LENGTH 0 after this ID: FF FF FD 00 is a Protocol 2.0 header. */
#define PROTOCOL2_ID 0xFDu

uint8_t dxl_frame_step(dxl_frame_t *frame, uint8_t byte) {
  const uint8_t state = frame->state;
  if (state == DXL_FRAME_BODY) {
    frame->sum = (uint8_t)(frame->sum + byte);
    if (--frame->left != 0) {
      return DXL_BYTE_BODY;
    }
    frame->state = DXL_FRAME_SEARCH;
    return frame->sum == 0xFFu ? DXL_BYTE_CHECKSUM : DXL_BYTE_CHECKSUM_BAD; /* checksum = ~(ID + LENGTH + body) */
  }
  if (state >= DXL_FRAME_P2_ID) {
    if (state == DXL_FRAME_P2_DATA) {
      if (frame->left-- == 0) {
        frame->left_high--;
      }
      if ((frame->left | frame->left_high) == 0) {
        frame->state = DXL_FRAME_SEARCH;
      }
      return DXL_BYTE_PROTOCOL2;
    }
    if (state == DXL_FRAME_P2_LENGTH_L) {
      frame->left = byte;
    } else if (state == DXL_FRAME_P2_LENGTH_H) {
      frame->left_high = byte;
      if ((frame->left | byte) == 0) {
        frame->state = DXL_FRAME_SEARCH;
        return DXL_BYTE_PROTOCOL2;
      }
    }
    frame->state = (uint8_t)(state + 1u);
    return DXL_BYTE_PROTOCOL2;
  }
  if (state == DXL_FRAME_LENGTH) {
    frame->length = byte;
    if (byte >= 2u) {
      frame->left = byte;
      frame->sum = (uint8_t)(frame->sum + byte);
      frame->state = DXL_FRAME_BODY;
      return DXL_BYTE_LENGTH;
    }
    if (byte == 0 && frame->id == PROTOCOL2_ID) {
      frame->state = DXL_FRAME_P2_ID;
      return DXL_BYTE_PROTOCOL2;
    }
    frame->state = DXL_FRAME_SEARCH;
    return DXL_BYTE_GARBAGE;
  }
  if (state == DXL_FRAME_ID) {
    if (byte != DXL_HEADER_BYTE) { /* a further 0xFF is still the header */
      frame->id = byte;
      frame->sum = byte;
      frame->state = DXL_FRAME_LENGTH;
    }
    return DXL_BYTE_HEADER;
  }
  /* SEARCH, SECOND_FF: an 0xFF moves on, anything else is garbage */
  if (byte == DXL_HEADER_BYTE) {
    frame->state = (uint8_t)(state + 1u);
    return DXL_BYTE_HEADER;
  }
  frame->state = DXL_FRAME_SEARCH;
  return DXL_BYTE_GARBAGE;
}
