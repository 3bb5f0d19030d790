/* The bootloader's packet framer. See boot_frame.h. */
#include "boot_frame.h"

#include "dxl_protocol.h"

enum { WAIT_FF, WAIT_SECOND_FF, WAIT_ID, WAIT_LENGTH, IN_BODY };

void boot_frame_init(boot_frame_t *frame) { frame->state = WAIT_FF; }

bool boot_frame_push(boot_frame_t *frame, uint8_t byte, uint16_t now_ms, dxl_packet_t *packet) {
  if ((uint16_t)(now_ms - frame->last_byte_ms) > DXL_PACKET_GAP_TIMEOUT_MS) {
    frame->state = WAIT_FF;
  }
  frame->last_byte_ms = now_ms;
  switch (frame->state) {
  case WAIT_FF:
    frame->state = byte == 0xFFu ? WAIT_SECOND_FF : WAIT_FF;
    break;
  case WAIT_SECOND_FF:
    frame->state = byte == 0xFFu ? WAIT_ID : WAIT_FF;
    break;
  case WAIT_ID: /* further 0xFF are still the header */
    if (byte != 0xFFu) {
      frame->id = byte;
      frame->state = WAIT_LENGTH;
    }
    break;
  case WAIT_LENGTH:
    frame->length = byte;
    frame->sum = (uint8_t)(frame->id + byte);
    frame->fill = 0;
    frame->state = (byte >= DXL_PACKET_MIN_LENGTH && byte <= BOOT_FRAME_MAX_LENGTH) ? IN_BODY : WAIT_FF;
    break;
  default: /* IN_BODY */
    if (frame->fill + 1u < frame->length) {
      frame->body[frame->fill++] = byte;
      frame->sum = (uint8_t)(frame->sum + byte);
      break;
    }
    frame->state = WAIT_FF;
    if ((uint8_t)(frame->sum + byte) == 0xFFu) { /* checksum = ~sum */
      packet->id = frame->id;
      packet->instruction = frame->body[0];
      packet->param_count = (uint8_t)(frame->length - 2u);
      packet->params = &frame->body[1];
      packet->checksum = byte;
      return true;
    }
    break;
  }
  return false;
}
