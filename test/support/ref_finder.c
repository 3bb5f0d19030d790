/* The reference finder. See ref_finder.h. */
#include "ref_finder.h"

#include <string.h>

#include "dxl_protocol.h"

#define PROTOCOL2_ID 0xFDu
#define PROTOCOL2_HEADER_BYTES 7u

void ref_finder_init(ref_finder_t *ref) { memset(ref, 0, sizeof *ref); }

/* Complete packets were framed as their last byte came (frame_held): a gap drops only the
 * bytes of what was under way. */
static void gap_check(ref_finder_t *ref, uint16_t now_ms) {
  if (ref->any_byte && (uint16_t)(now_ms - ref->last_byte_ms) > DXL_PACKET_GAP_TIMEOUT_MS) {
    ref->consumed += ref->count;
    ref->count = 0;
    ref->skip = 0;
  }
}

static bool frame_held(ref_finder_t *ref);

bool ref_finder_push(ref_finder_t *ref, uint8_t byte, uint16_t now_ms) {
  gap_check(ref, now_ms);
  ref->any_byte = true;
  ref->last_byte_ms = now_ms;
  if (ref->skip != 0 && ref->count == 0) {
    ref->skip--; /* a byte of a Protocol 2.0 frame */
    ref->consumed++;
    return true;
  }
  if (ref->count == REF_FINDER_CAPACITY) {
    return false;
  }
  ref->bytes[ref->count++] = byte;
  return frame_held(ref);
}

void ref_finder_poll(ref_finder_t *ref, uint16_t now_ms) { gap_check(ref, now_ms); }

static void consume(ref_finder_t *ref, size_t n) {
  memmove(ref->bytes, ref->bytes + n, ref->count - n);
  ref->count -= n;
  ref->consumed += n;
}

/* The packet at the front of the bytes held, if they hold all of it, into out; NONE when they
 * need more. */
static dxl_find_result_t frame_front(ref_finder_t *ref, ref_packet_t *out) {
  for (;;) {
    while (ref->skip != 0 && ref->count != 0) {
      consume(ref, 1); /* a byte of a Protocol 2.0 frame */
      ref->skip--;
    }
    const uint8_t *b = ref->bytes;
    const size_t n = ref->count;
    if (n == 0) {
      return DXL_FIND_NONE;
    }
    if (b[0] != DXL_HEADER_BYTE) {
      consume(ref, 1);
      continue;
    }
    if (n < 2) {
      return DXL_FIND_NONE;
    }
    if (b[1] != DXL_HEADER_BYTE) {
      consume(ref, 1);
      continue;
    }
    if (n < 4) {
      if (n == 3 && b[2] == DXL_HEADER_BYTE) {
        consume(ref, 1);
        continue;
      }
      return DXL_FIND_NONE;
    }
    if (b[2] == DXL_HEADER_BYTE) {
      consume(ref, 1);
      continue;
    }
    const uint8_t id = b[2];
    const uint8_t length = b[3];
    if (length == 0 && id == PROTOCOL2_ID) {
      if (n < PROTOCOL2_HEADER_BYTES) {
        return DXL_FIND_NONE;
      }
      ref->skip = (unsigned)(b[5] | (b[6] << 8));
      consume(ref, PROTOCOL2_HEADER_BYTES);
      continue;
    }
    if (length < DXL_PACKET_MIN_LENGTH) {
      consume(ref, 4);
      continue;
    }
    const size_t total = 4u + length;
    if (n < total) {
      return DXL_FIND_NONE;
    }
    unsigned sum = 0;
    for (size_t i = 2; i + 1 < total; i++) {
      sum += b[i];
    }
    out->start = ref->consumed;
    out->id = id;
    out->instruction = b[4];
    out->param_count = (uint8_t)(length - 2u);
    memcpy(out->params, &b[5], out->param_count);
    out->checksum = b[total - 1];
    out->result = (uint8_t)~sum == out->checksum ? DXL_FIND_PACKET : DXL_FIND_BAD_CHECKSUM;
    consume(ref, total);
    return out->result;
  }
}

/* Frames every packet the bytes held complete, into the queue; false when it is full. */
static bool frame_held(ref_finder_t *ref) {
  for (;;) {
    if (ref->found_count == REF_FINDER_QUEUE) {
      return false;
    }
    ref_packet_t *slot = &ref->found[(ref->found_first + ref->found_count) % REF_FINDER_QUEUE];
    if (frame_front(ref, slot) == DXL_FIND_NONE) {
      return true;
    }
    ref->found_count++;
  }
}

dxl_find_result_t ref_finder_next(ref_finder_t *ref, ref_packet_t *out) {
  if (ref->found_count == 0) {
    return DXL_FIND_NONE;
  }
  *out = ref->found[ref->found_first];
  ref->found_first = (ref->found_first + 1u) % REF_FINDER_QUEUE;
  ref->found_count--;
  return out->result;
}
