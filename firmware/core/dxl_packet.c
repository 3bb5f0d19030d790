#include "dxl_packet.h"

#include <string.h>

#include "dxl_config.h"
#include "dxl_protocol.h"

/* Offsets in a candidate: FF FF ID LENGTH INSTRUCTION PARAMS... CHECKSUM */
#define OFS_ID 2u
#define OFS_LENGTH 3u
#define OFS_INSTRUCTION 4u
#define OFS_PARAMS 5u
#define HEADER_BYTES 4u
/* A Protocol 2.0 frame: FF FF FD 00 ID LEN_L LEN_H, then LEN bytes (instruction, parameters,
 * CRC). FF FF FD 00 is no 1.0 header: LENGTH 0. */
#define PROTOCOL2_HEADER3 0xFDu
#define PROTOCOL2_OFS_LENGTH 5u
#define PROTOCOL2_HEADER_BYTES 7u

void dxl_finder_init(dxl_finder_t *finder) { memset(finder, 0, sizeof *finder); }

uint8_t dxl_checksum(const uint8_t *id_length_body, uint16_t count) {
  uint8_t sum = 0;
  for (uint16_t i = 0; i < count; i++) {
    sum = (uint8_t)(sum + id_length_body[i]);
  }
  return (uint8_t)~sum;
}

/* The move comes last, a tail call: nothing of f needs keeping across it (its frame 8 -> 2 B
 * and 24 B less flash on the ATmega88, measured). count <= DXL_PACKET_MAX_BYTES. */
static void drop_front(dxl_finder_t *f, uint16_t count) {
  const uint16_t kept = count >= f->fill ? 0u : (uint16_t)(f->fill - count);
  f->fill = kept;
  f->before_gap = (count >= f->before_gap) ? 0 : (uint16_t)(f->before_gap - count);
  f->examined = 0;
  f->sum = 0;
  if (kept != 0) {
    memmove(f->bytes, f->bytes + count, kept);
  }
}

/* One copy for dxl_finder_next() and dxl_finder_push_slot(), the move a tail call: 16 B less
 * flash on the ATmega88. */
static DXL_ONE_COPY void apply_release(dxl_finder_t *f) {
  const uint16_t release = f->release;
  if (release != 0) {
    f->release = 0;
    drop_front(f, release); /* a tail call (drop_front leaves release alone) */
  }
}

static uint16_t candidate_total_bytes(const dxl_finder_t *f) {
  return (uint16_t)(HEADER_BYTES + f->bytes[OFS_LENGTH]);
}

/* One copy: the finder's checksum step and dxl_finder_candidate() (the armed path) share it
 * (20 B less flash on the ATmega88). */
static DXL_ONE_COPY void describe(const dxl_finder_t *f, dxl_packet_t *p) {
  p->id = f->bytes[OFS_ID];
  p->instruction = f->bytes[OFS_INSTRUCTION];
  p->param_count = (uint8_t)(f->bytes[OFS_LENGTH] - DXL_PACKET_MIN_LENGTH);
  p->params = &f->bytes[OFS_PARAMS];
  p->checksum = f->bytes[candidate_total_bytes(f) - 1u];
}

void dxl_finder_candidate(const dxl_finder_t *finder, dxl_packet_t *packet) { describe(finder, packet); }

const uint8_t *dxl_finder_held(const dxl_finder_t *finder) { return finder->bytes; }

bool dxl_finder_poll(dxl_finder_t *finder, uint16_t now_ms) {
  DXL_OPAQUE(finder); /* 50 B less flash on the ATmega88 (measured) */
  if ((uint16_t)(now_ms - finder->last_byte_ms) > DXL_PACKET_GAP_TIMEOUT_MS) {
    finder->skip_left = 0; /* a 2.0 frame cut by the gap ends with it */
    if (finder->fill != 0 && finder->before_gap != finder->fill) {
      finder->before_gap = finder->fill;
      return true;
    }
  }
  return false;
}

/* Drops what has come of the Protocol 2.0 frame being skipped. */
static void skip_protocol2(dxl_finder_t *f) {
  const uint16_t count = f->skip_left < f->fill ? f->skip_left : f->fill;
  drop_front(f, count);
  f->skip_left = (uint16_t)(f->skip_left - count);
}

uint8_t *dxl_finder_push_slot(dxl_finder_t *finder, uint16_t *room, uint16_t now_ms) {
  dxl_finder_poll(finder, now_ms);
  apply_release(finder);
  *room = (uint16_t)(DXL_PACKET_MAX_BYTES - finder->fill);
  return &finder->bytes[finder->fill];
}

void dxl_finder_pushed(dxl_finder_t *finder, uint16_t count, uint16_t now_ms) {
  DXL_OPAQUE(finder); /* 8 B less flash on the ATmega88 (measured) */
  if (count != 0) { /* no byte came: the gap since the last one goes on */
    finder->fill = (uint16_t)(finder->fill + count);
    finder->last_byte_ms = now_ms;
  }
}

void dxl_finder_push(dxl_finder_t *finder, uint8_t byte, uint16_t now_ms) {
  uint16_t room;
  uint8_t *slot = dxl_finder_push_slot(finder, &room, now_ms);
  if (room == 0) {
    drop_front(finder, 1); /* only if the caller skipped dxl_finder_next(): keep going */
    slot--;
  }
  *slot = byte;
  dxl_finder_pushed(finder, 1u, now_ms);
}

/* Sums the candidate's body bytes that are in, up to (not including) its checksum and not
 * past a gap: the per-byte fast path (a few cycles a byte on the AVR). */
static void sum_body(dxl_finder_t *f) {
  uint16_t end = (uint16_t)(candidate_total_bytes(f) - 1u);
  if (end > f->fill) {
    end = f->fill;
  }
  if (f->before_gap != 0 && end > f->before_gap) {
    end = f->before_gap;
  }
  uint8_t sum = f->sum;
  const uint8_t *byte = &f->bytes[f->examined];
  for (uint16_t n = (uint16_t)(end - f->examined); n != 0; n--) {
    sum = (uint8_t)(sum + *byte++);
  }
  f->sum = sum;
  f->examined = end;
}

dxl_find_result_t dxl_finder_next(dxl_finder_t *finder, dxl_packet_t *packet) {
  dxl_finder_t *f = finder;
  DXL_OPAQUE(f); /* the fields by displacement from Y: 56 B less flash on the ATmega88 */
  apply_release(f);
  for (;;) {
    if (f->skip_left != 0) {
      skip_protocol2(f);
      if (f->skip_left != 0) {
        return DXL_FIND_NONE;
      }
    }
    if (f->examined > OFS_LENGTH) {
      sum_body(f);
    }
    if (f->before_gap != 0 && f->examined == f->before_gap) {
      drop_front(f, 1); /* the candidate would run across a gap: not a packet */
      continue;
    }
    if (f->examined >= f->fill) {
      return DXL_FIND_NONE;
    }
    const uint8_t b = f->bytes[f->examined];
    switch (f->examined) {
    case 0: { /* first header byte: no packet starts before the next FF FF (or an FF that is the
               * last byte in), drop up to it at once: one move for a run of garbage and lone
               * 0xFFs, not one each (a rescan would otherwise move the bytes behind every lone
               * 0xFF of a rejected candidate) */
      uint16_t garbage = 0;
      while (garbage < f->fill && (f->bytes[garbage] != DXL_HEADER_BYTE ||
                                   (garbage + 1u < f->fill && f->bytes[garbage + 1u] != DXL_HEADER_BYTE))) {
        garbage++;
      }
      if (garbage != 0) {
        drop_front(f, garbage);
        continue;
      }
      break;
    }
    case 1: /* second header byte */
      if (b != DXL_HEADER_BYTE) {
        drop_front(f, 2);
        continue;
      }
      break;
    case OFS_ID:
      if (b == DXL_HEADER_BYTE) { /* a third 0xFF: still the header */
        drop_front(f, 1);
        continue;
      }
      f->sum = b;
      break;
    case OFS_LENGTH:
      if (b < DXL_PACKET_MIN_LENGTH) {
        if (b == 0 && f->bytes[OFS_ID] == PROTOCOL2_HEADER3) { /* FF FF FD 00: Protocol 2.0 */
          const uint16_t in = f->before_gap != 0 ? f->before_gap : f->fill;
          if (in >= PROTOCOL2_HEADER_BYTES) {
            f->skip_left = (uint16_t)(f->bytes[PROTOCOL2_OFS_LENGTH] | ((uint16_t)f->bytes[PROTOCOL2_OFS_LENGTH + 1u] << 8));
            drop_front(f, PROTOCOL2_HEADER_BYTES); /* the rest goes at the top of the loop */
            continue;
          }
          if (f->before_gap == 0) {
            return DXL_FIND_NONE; /* its length is still on the wire */
          }
        }
        drop_front(f, 1);
        continue;
      }
      f->sum = (uint8_t)(f->sum + b);
      break;
    default: /* the checksum: sum_body() has taken every byte before it */
      f->examined++;
      describe(f, packet);
      const uint8_t expected_checksum = (uint8_t)~f->sum;
      if (expected_checksum == b) {
        f->release = f->examined; /* the whole packet */
        return DXL_FIND_PACKET;
      }
      f->release = 1; /* rescan from the second byte of the candidate */
      return DXL_FIND_BAD_CHECKSUM;
    }
    f->examined++;
  }
}
