/* The packet finder: turns a byte stream (fed one byte or one batch at a time) into Protocol
 * 1.0 packets.
 *
 * Framing (docs/policy.md "Framing and bus"): two or more 0xFF, ID (0..0xFE), LENGTH (>= 2),
 * LENGTH-1 bytes of instruction and parameters, checksum = ~(ID + LENGTH + body) & 0xFF.
 * Packets for any ID, and other servos' status packets, are framed the same way; choosing
 * what to act on is the caller's business.
 *
 * Protocol 2.0 frames (FF FF FD 00 ID LEN_L LEN_H ..., docs/policy.md "Framing and bus"): a
 * header FF FF FD 00 cannot start a 1.0 packet (LENGTH 0); once its 16-bit length is in, the
 * whole frame is dropped as it arrives (skip_left), and nothing inside it is framed. A gap
 * ends such a frame like any partial packet.
 *
 * Resynchronisation: the finder keeps the bytes of the candidate packet. A LENGTH below 2 or
 * a wrong checksum drops only the first byte of the candidate and rescans the rest, so a valid
 * packet that starts inside garbage is still found. No packet spans a gap of more than
 * DXL_PACKET_GAP_TIMEOUT_MS between two bytes: the bytes before such a gap are rescanned on
 * their own (a complete packet hidden behind a garbage header is still found) and what is left
 * of them is discarded.
 *
 * Use: dxl_finder_push() one byte (or a batch, dxl_finder_push_slot()), then call
 * dxl_finder_next() until it returns DXL_FIND_NONE (one byte can complete more than one
 * packet after a rescan). A returned packet's params point into the finder and stay valid
 * until the next push or next call.
 *
 * Cost: the body bytes of a candidate are summed in one tight loop (sum_body), so a batch
 * costs a few cycles a byte plus a fixed amount per header byte and per packet.
 *
 * Time is passed in (milliseconds, any origin, wrapping at 2^16); the finder never reads a
 * clock. Worst-case rescan work after a bad checksum is O(n^2) in the candidate length
 * (n <= 259), only for adversarial garbage.
 */
#ifndef DXL_PACKET_H
#define DXL_PACKET_H

#include <stdbool.h>
#include <stdint.h>

#define DXL_PACKET_MAX_BYTES 259u /* FF FF ID LENGTH + LENGTH (<= 255) bytes */
#define DXL_PACKET_MIN_LENGTH 2u  /* instruction + checksum */

typedef struct {
  uint8_t id;
  uint8_t instruction; /* the error byte, when this is another servo's status packet */
  uint8_t param_count; /* LENGTH - 2 */
  const uint8_t *params;
  uint8_t checksum; /* as received */
} dxl_packet_t;

typedef enum {
  DXL_FIND_NONE = 0,         /* nothing (more) until further bytes arrive */
  DXL_FIND_PACKET,           /* a packet with a good checksum */
  DXL_FIND_BAD_CHECKSUM,     /* a framed packet whose checksum is wrong; its fields are reported */
} dxl_find_result_t;

/* The counters first: within reach of the AVR's 0..63 load/store displacement (DXL_OPAQUE). */
typedef struct {
  uint16_t fill;        /* bytes held */
  uint16_t examined;    /* leading bytes of bytes[] accepted as the candidate so far */
  uint16_t release;     /* bytes to drop before the next scan (a returned result's) */
  uint16_t before_gap;  /* leading bytes that came before a gap: no packet runs past them */
  uint8_t sum;          /* ID + LENGTH + body over the examined bytes */
  uint16_t last_byte_ms;
  uint16_t skip_left;   /* bytes of a Protocol 2.0 frame still to come, dropped as they do */
  uint8_t bytes[DXL_PACKET_MAX_BYTES];
} dxl_finder_t;

/* Empties the finder: all zeros (a finder zeroed with its container is initialised). */
void dxl_finder_init(dxl_finder_t *finder);
void dxl_finder_push(dxl_finder_t *finder, uint8_t byte, uint16_t now_ms);

/* Batch push, the same as dxl_finder_push() for each byte at one now_ms: push_slot returns
 * where the next byte goes and sets *room to how many fit (0 when the finder is full: call
 * dxl_finder_next() first); the caller writes up to
 * that many there, then reports them with dxl_finder_pushed(). Nothing else in between. */
uint8_t *dxl_finder_push_slot(dxl_finder_t *finder, uint16_t *room, uint16_t now_ms);
void dxl_finder_pushed(dxl_finder_t *finder, uint16_t count, uint16_t now_ms);
dxl_find_result_t dxl_finder_next(dxl_finder_t *finder, dxl_packet_t *packet);

/* Ends the bytes held so far if no byte came for more than DXL_PACKET_GAP_TIMEOUT_MS, and
 * returns true when it did: call dxl_finder_next() afterwards until it returns DXL_FIND_NONE
 * (a packet hidden in them is found now, not when the next byte comes), before the next poll
 * or push (which polls): the finder marks one gap, and another one marked before then moves
 * the mark past the bytes between the two. Call it now and then while idle (the gap is also
 * checked on every push). */
bool dxl_finder_poll(dxl_finder_t *finder, uint16_t now_ms);

/* True when the finder holds nothing and is not in a Protocol 2.0 frame: the next byte
 * starts a new candidate. (Two returns, not one &&: 8 B less flash on the ATmega88.) */
static inline bool dxl_finder_idle(const dxl_finder_t *finder) {
  if (finder->fill != finder->release) {
    return false;
  }
  return finder->skip_left == 0;
}

/* The candidate as examined so far: valid once its instruction has been examined (and the
 * finder returned DXL_FIND_NONE since); its checksum field is meaningful only once the
 * checksum is in. Lets the caller prepare a reply while the last bytes are still on the
 * wire, when it knows from elsewhere (the firmware's sniff) where the candidate ends. */
void dxl_finder_candidate(const dxl_finder_t *finder, dxl_packet_t *packet);

/* The bytes held, fill of them (the candidate first): a returned packet is the first
 * 4 + LENGTH of them until the next push or next call. */
const uint8_t *dxl_finder_held(const dxl_finder_t *finder);

/* The Protocol 1.0 checksum of ID, LENGTH and the body bytes. */
uint8_t dxl_checksum(const uint8_t *id_length_body, uint16_t count);

#endif
