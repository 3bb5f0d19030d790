#include "dxl_packet.h"

#include <string.h>

#include "dxl_protocol.h"

/* Offsets in a held packet: FF FF ID LENGTH INSTRUCTION PARAMS... CHECKSUM */
#define OFS_ID 2u
#define OFS_LENGTH 3u
#define OFS_INSTRUCTION 4u
#define OFS_PARAMS 5u

void dxl_finder_init(dxl_finder_t *finder) { memset(finder, 0, sizeof *finder); }

uint8_t dxl_checksum(const uint8_t *id_length_body, uint16_t count) {
  uint8_t sum = 0;
  for (uint16_t i = 0; i < count; i++) {
    sum = (uint8_t)(sum + id_length_body[i]);
  }
  return (uint8_t)~sum;
}

void dxl_finder_candidate(const dxl_finder_t *finder, dxl_packet_t *packet) {
  const uint8_t *bytes = finder->bytes;
  packet->id = bytes[OFS_ID];
  packet->instruction = bytes[OFS_INSTRUCTION];
  packet->param_count = (uint8_t)(bytes[OFS_LENGTH] - DXL_PACKET_MIN_LENGTH);
  packet->params = &bytes[OFS_PARAMS];
  packet->checksum = bytes[OFS_LENGTH + bytes[OFS_LENGTH]];
}

void dxl_finder_gap(dxl_finder_t *finder) {
  dxl_frame_reset(&finder->frame);
  finder->fill = 0;
}

uint8_t *dxl_finder_slot(dxl_finder_t *finder, uint16_t *count) {
  if (finder->frame.state == DXL_FRAME_BODY) {
    *count = finder->frame.left;
    return &finder->bytes[finder->fill];
  }
  /* A header byte, one at a time: it is not held (the header is written whole at its
   * LENGTH), and the packet returned last is let go. */
  finder->fill = 0;
  *count = 1;
  return finder->bytes;
}

dxl_find_result_t dxl_finder_pushed(dxl_finder_t *finder, uint16_t count, dxl_packet_t *packet) {
  dxl_frame_t *frame = &finder->frame;
  if (count == 0) {
    return DXL_FIND_NONE;
  }
  if (frame->state != DXL_FRAME_BODY) {
    if (dxl_frame_step(frame, finder->bytes[0]) == DXL_BYTE_LENGTH) {
      uint8_t *bytes = finder->bytes;
      bytes[0] = DXL_HEADER_BYTE;
      bytes[1] = DXL_HEADER_BYTE;
      bytes[OFS_ID] = frame->id;
      bytes[OFS_LENGTH] = frame->length;
      finder->fill = DXL_PACKET_HEADER_BYTES;
    }
    return DXL_FIND_NONE;
  }
  /* count (<= left) BODY steps of dxl_frame_step() at once: each byte summed, counted down;
   * the last of the packet is its checksum. The per-byte fast path of the receive path. */
  uint8_t sum = frame->sum;
  const uint8_t *byte = &finder->bytes[finder->fill];
  for (uint16_t n = count; n != 0; n--) {
    sum = (uint8_t)(sum + *byte++);
  }
  frame->sum = sum;
  finder->fill = (uint16_t)(finder->fill + count);
  frame->left = (uint8_t)(frame->left - count);
  if (frame->left != 0) {
    return DXL_FIND_NONE;
  }
  dxl_frame_reset(frame);
  dxl_finder_candidate(finder, packet);
  return sum == 0xFFu ? DXL_FIND_PACKET : DXL_FIND_BAD_CHECKSUM; /* checksum = ~(ID + LENGTH + body) */
}

dxl_find_result_t dxl_finder_push(dxl_finder_t *finder, uint8_t byte, dxl_packet_t *packet) {
  uint16_t count;
  *dxl_finder_slot(finder, &count) = byte;
  return dxl_finder_pushed(finder, 1u, packet);
}
