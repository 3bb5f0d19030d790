/* The reference finder. See ref_finder.h. */
#include "ref_finder.h"

#include <string.h>

#include "dxl_protocol.h"

void ref_finder_init(ref_finder_t *ref) { memset(ref, 0, sizeof *ref); }

static bool gap_since_last_byte(const ref_finder_t *ref, uint16_t now_ms) {
  return (uint16_t)(now_ms - ref->last_byte_ms) > DXL_PACKET_GAP_TIMEOUT_MS;
}

bool ref_finder_push(ref_finder_t *ref, uint8_t byte, uint16_t now_ms) {
  if (ref->count == REF_FINDER_CAPACITY) {
    return false;
  }
  if (gap_since_last_byte(ref, now_ms)) {
    ref->skip = 0; /* a gap ends a Protocol 2.0 frame */
  }
  ref->gap_before[ref->count] = ref->count != 0 && (ref->gap_at_end || gap_since_last_byte(ref, now_ms));
  ref->bytes[ref->count] = byte;
  ref->count++;
  ref->gap_at_end = false;
  ref->last_byte_ms = now_ms;
  return true;
}

void ref_finder_poll(ref_finder_t *ref, uint16_t now_ms) {
  if (gap_since_last_byte(ref, now_ms)) {
    ref->skip = 0;
    if (ref->count != 0) {
      ref->gap_at_end = true;
    }
  }
}

static void consume(ref_finder_t *ref, size_t n) {
  memmove(ref->bytes, ref->bytes + n, ref->count - n);
  memmove(ref->gap_before, ref->gap_before + n, (ref->count - n) * sizeof ref->gap_before[0]);
  ref->count -= n;
}

/* What the front of the held bytes is. */
typedef enum { FRONT_NOT_A_PACKET, FRONT_WAIT, FRONT_COMPLETE, FRONT_PROTOCOL2 } front_t;

#define PROTOCOL2_ID 0xFDu
#define PROTOCOL2_HEADER_BYTES 7u

static front_t look_at_front(const ref_finder_t *ref, size_t *total) {
  /* The bytes a packet needs from the front: 4 until LENGTH is known. */
  size_t needed = 4;
  bool protocol2 = false;
  for (size_t i = 0; i < needed; i++) {
    if (i == ref->count) {
      return ref->gap_at_end ? FRONT_NOT_A_PACKET : FRONT_WAIT;
    }
    if (i > 0 && ref->gap_before[i]) {
      return FRONT_NOT_A_PACKET; /* no packet spans a gap */
    }
    const uint8_t b = ref->bytes[i];
    if (i == 3 && b == 0 && ref->bytes[2] == PROTOCOL2_ID) {
      protocol2 = true; /* FF FF FD 00: the header of a 2.0 frame, 7 bytes */
      needed = PROTOCOL2_HEADER_BYTES;
      continue;
    }
    if (protocol2) {
      continue;
    }
    if ((i < 2 && b != DXL_HEADER_BYTE) || (i == 2 && b == DXL_HEADER_BYTE) ||
        (i == 3 && b < DXL_PACKET_MIN_LENGTH)) {
      return FRONT_NOT_A_PACKET;
    }
    if (i == 3) {
      needed = 4u + b;
    }
  }
  *total = needed;
  return protocol2 ? FRONT_PROTOCOL2 : FRONT_COMPLETE;
}

dxl_find_result_t ref_finder_next(ref_finder_t *ref, ref_packet_t *out) {
  for (;;) {
    while (ref->skip != 0 && ref->count != 0) {
      consume(ref, 1); /* a byte of the Protocol 2.0 frame */
      ref->skip--;
    }
    if (ref->skip != 0) {
      return DXL_FIND_NONE;
    }
    size_t total = 0;
    switch (look_at_front(ref, &total)) {
    case FRONT_WAIT:
      return DXL_FIND_NONE;
    case FRONT_PROTOCOL2:
      ref->skip = (unsigned)(ref->bytes[5] | (ref->bytes[6] << 8));
      consume(ref, PROTOCOL2_HEADER_BYTES);
      continue;
    case FRONT_NOT_A_PACKET:
      if (ref->count == 0) {
        return DXL_FIND_NONE;
      }
      consume(ref, 1);
      continue;
    case FRONT_COMPLETE:
      break;
    }
    const uint8_t *p = ref->bytes;
    unsigned sum = 0;
    for (size_t i = 2; i + 1 < total; i++) {
      sum += p[i];
    }
    const uint8_t checksum = p[total - 1];
    out->id = p[2];
    out->instruction = p[4];
    out->param_count = (uint8_t)(p[3] - 2u);
    memcpy(out->params, &p[5], out->param_count);
    out->checksum = checksum;
    if ((uint8_t)~sum == checksum) {
      out->result = DXL_FIND_PACKET;
      consume(ref, total);
    } else {
      out->result = DXL_FIND_BAD_CHECKSUM;
      consume(ref, 1);
    }
    return out->result;
  }
}
