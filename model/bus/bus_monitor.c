/* SPDX-License-Identifier: MIT */
#include "bus_monitor.h"

#include <stdlib.h>
#include <string.h>

#include "packet_encode.h"

/* Protocol 1.0 as the manual gives it (not the firmware's header: the monitor watches the
 * firmware, as packet_encode.c does). */
#define HEADER_BYTE 0xFFu
#define SHORTEST_LENGTH 2u /* LENGTH of a packet with no parameters: code + checksum */
/* Protocol 2.0: FF FF FD 00 ID LEN_L LEN_H, then LEN bytes (instruction, params, CRC). */
#define P2_ID_BYTE 0xFDu
#define P2_RESERVED_BYTE 0x00u
#define P2_BYTES_AFTER_HEADER 5u /* FD 00 ID LEN_L LEN_H */

_Static_assert(BUS_MONITOR_MAX_RAW >= 2u + 2u + 255u, "a record holds the longest 1.0 packet");

/* One byte of a sender, kept until its record is reported. */
typedef struct {
  sim_cycles_t start, end;
  uint8_t value; /* as sent */
  uint8_t flags; /* BUS_RX_* */
  bool noise;    /* the wire carried another value */
} mon_byte_t;

/* What one sender has sent that is not reported yet. */
typedef struct {
  mon_byte_t candidate[BUS_MONITOR_MAX_RAW]; /* bytes from a possible header on */
  size_t candidate_count;
  mon_byte_t garbage[BUS_MONITOR_MAX_RAW]; /* the garbage before them */
  size_t garbage_count;
  uint32_t p2_left; /* bytes of a 2.0 frame still to come after candidate[] (swallowing) */
  sim_cycles_t last_end;
  bool listed; /* in open[] */
} sender_t;

typedef struct {
  bus_packet_fn fn;
  void *ctx;
} listener_t;

struct bus_monitor {
  bus_t *bus;
  sim_cycles_t gap;
  int client; /* node index, -1 for none */
  bool master[BUS_MAX_NODES]; /* other nodes whose packets are instructions */
  sender_t *senders[BUS_MAX_NODES]; /* allocated at a node's first byte */
  uint8_t open[BUS_MAX_NODES];      /* senders with bytes not reported */
  size_t open_count;
  listener_t listeners[BUS_MONITOR_MAX_LISTENERS];
  uint64_t counts[BUS_PACKET_PROTOCOL2 + 1];
  uint64_t dropped_bytes; /* no memory for a sender */
};

bus_monitor_t *bus_monitor_create(bus_t *bus, sim_cycles_t gap) {
  bus_monitor_t *mon = calloc(1, sizeof(*mon));
  if (!mon) {
    return NULL;
  }
  mon->bus = bus;
  mon->gap = gap;
  mon->client = -1;
  bus_set_tap(bus, bus_monitor_byte, mon);
  return mon;
}

void bus_monitor_destroy(bus_monitor_t *mon) {
  if (!mon) {
    return;
  }
  if (mon->bus->tap_ctx == mon) {
    bus_set_tap(mon->bus, NULL, NULL);
  }
  for (size_t i = 0; i < BUS_MAX_NODES; i++) {
    free(mon->senders[i]);
  }
  free(mon);
}

void bus_monitor_set_client(bus_monitor_t *mon, int node) { mon->client = node; }

void bus_monitor_add_master(bus_monitor_t *mon, int node) {
  if (node >= 0 && node < (int)BUS_MAX_NODES) {
    mon->master[node] = true;
  }
}

static bool sends_instructions(const bus_monitor_t *mon, unsigned sender) {
  return (int)sender == mon->client || mon->master[sender];
}

int bus_monitor_add_listener(bus_monitor_t *mon, bus_packet_fn fn, void *ctx) {
  for (size_t i = 0; i < BUS_MONITOR_MAX_LISTENERS; i++) {
    if (!mon->listeners[i].fn) {
      mon->listeners[i] = (listener_t){.fn = fn, .ctx = ctx};
      return (int)i;
    }
  }
  return -1;
}

void bus_monitor_remove_listener(bus_monitor_t *mon, int handle) {
  if (handle >= 0 && (size_t)handle < BUS_MONITOR_MAX_LISTENERS) {
    mon->listeners[handle] = (listener_t){0};
  }
}

uint64_t bus_monitor_count(const bus_monitor_t *mon, bus_packet_kind_t kind) { return mon->counts[kind]; }

/* ---- reporting ---- */

static void report(bus_monitor_t *mon, uint8_t sender, bus_packet_kind_t kind, const mon_byte_t *bytes, size_t count) {
  if (count == 0) {
    return;
  }
  uint8_t raw[BUS_MONITOR_MAX_RAW];
  bus_packet_t p;
  memset(&p, 0, sizeof(p));
  p.kind = kind;
  p.start = bytes[0].start;
  p.end = bytes[count - 1u].end;
  p.sender = sender;
  p.sender_name = (int)sender == mon->client ? "client" : mon->bus->nodes[sender].name;
  for (size_t i = 0; i < count; i++) {
    raw[i] = bytes[i].value;
    p.line_flags |= bytes[i].flags;
    p.noise_changed |= bytes[i].noise;
  }
  p.collision = (p.line_flags & BUS_RX_COLLISION) != 0;
  p.raw = raw;
  p.raw_count = count;
  if (kind == BUS_PACKET_INSTRUCTION || kind == BUS_PACKET_STATUS) {
    size_t h = 2;
    while (raw[h] == HEADER_BYTE) {
      h++; /* extra header bytes: framing guarantees an ID after them */
    }
    p.id = raw[h];
    p.length = raw[h + 1u];
    p.code = raw[h + 2u];
    p.params = &raw[h + 3u];
    p.param_count = (size_t)p.length - SHORTEST_LENGTH;
    p.checksum = raw[count - 1u];
    p.checksum_ok = packet_checksum(&raw[h], count - 1u - h) == p.checksum;
  }
  mon->counts[kind]++;
  for (size_t i = 0; i < BUS_MONITOR_MAX_LISTENERS; i++) {
    if (mon->listeners[i].fn) {
      mon->listeners[i].fn(mon->listeners[i].ctx, &p);
    }
  }
}

static void report_garbage(bus_monitor_t *mon, uint8_t sender, sender_t *s) {
  report(mon, sender, BUS_PACKET_GARBAGE, s->garbage, s->garbage_count);
  s->garbage_count = 0;
}

/* Moves the first n candidate bytes out (reported by the caller). */
static void drop_candidate(sender_t *s, size_t n) {
  memmove(s->candidate, s->candidate + n, (s->candidate_count - n) * sizeof(mon_byte_t));
  s->candidate_count -= n;
}

/* The first candidate byte starts no packet: it joins the garbage. */
static void first_to_garbage(bus_monitor_t *mon, uint8_t sender, sender_t *s) {
  if (s->garbage_count == BUS_MONITOR_MAX_RAW) {
    report_garbage(mon, sender, s);
  }
  s->garbage[s->garbage_count++] = s->candidate[0];
  drop_candidate(s, 1);
}

/* ---- framing ---- */

typedef enum { FRAME_NEED_MORE, FRAME_NOT_PACKET, FRAME_PACKET, FRAME_PROTOCOL2 } frame_t;

/* What the candidate bytes begin with; *total is the size of the packet or 2.0 frame. */
static frame_t frame(const mon_byte_t *b, size_t count, size_t *total) {
  if (b[0].value != HEADER_BYTE) {
    return FRAME_NOT_PACKET;
  }
  if (count < 2u) {
    return FRAME_NEED_MORE;
  }
  if (b[1].value != HEADER_BYTE) {
    return FRAME_NOT_PACKET;
  }
  size_t h = 2; /* the ID's position, after any extra header bytes */
  while (h < count && b[h].value == HEADER_BYTE) {
    h++;
  }
  if (h + 2u > count) {
    return h + 2u + SHORTEST_LENGTH > BUS_MONITOR_MAX_RAW ? FRAME_NOT_PACKET : FRAME_NEED_MORE;
  }
  if (b[h].value == P2_ID_BYTE && b[h + 1u].value == P2_RESERVED_BYTE) {
    if (h + P2_BYTES_AFTER_HEADER > count) {
      return FRAME_NEED_MORE;
    }
    *total = h + P2_BYTES_AFTER_HEADER + ((size_t)b[h + 3u].value | ((size_t)b[h + 4u].value << 8));
    return FRAME_PROTOCOL2;
  }
  const size_t length = b[h + 1u].value;
  if (length < SHORTEST_LENGTH) {
    return FRAME_NOT_PACKET;
  }
  *total = h + 2u + length;
  if (*total > BUS_MONITOR_MAX_RAW) {
    return FRAME_NOT_PACKET; /* too many extra header bytes: drop them one by one */
  }
  return *total <= count ? FRAME_PACKET : FRAME_NEED_MORE;
}

/* Reports what the candidate bytes hold, as far as they go. `ending`: nothing more comes from
 * this sender for them (gap, another sender, finish): an incomplete packet is garbage. */
static void scan(bus_monitor_t *mon, uint8_t sender, sender_t *s, bool ending) {
  while (s->candidate_count > 0 && s->p2_left == 0) {
    size_t total = 0;
    const frame_t f = frame(s->candidate, s->candidate_count, &total);
    if (f == FRAME_PACKET) {
      report_garbage(mon, sender, s);
      report(mon, sender, sends_instructions(mon, sender) ? BUS_PACKET_INSTRUCTION : BUS_PACKET_STATUS, s->candidate,
             total);
      drop_candidate(s, total);
    } else if (f == FRAME_PROTOCOL2) {
      report_garbage(mon, sender, s);
      if (total <= s->candidate_count || ending) {
        const size_t n = total < s->candidate_count ? total : s->candidate_count;
        report(mon, sender, BUS_PACKET_PROTOCOL2, s->candidate, n);
        drop_candidate(s, n);
      } else if (total > BUS_MONITOR_MAX_RAW) {
        s->p2_left = (uint32_t)(total - s->candidate_count); /* swallowed as it comes */
      } else {
        return;
      }
    } else if (f == FRAME_NOT_PACKET || ending) {
      first_to_garbage(mon, sender, s);
    } else {
      return;
    }
  }
  if (ending) {
    if (s->p2_left) {
      report(mon, sender, BUS_PACKET_PROTOCOL2, s->candidate, s->candidate_count);
      s->candidate_count = 0;
      s->p2_left = 0;
    }
    report_garbage(mon, sender, s);
  }
}

/* ---- senders with bytes not reported ---- */

static bool has_bytes(const sender_t *s) { return s->candidate_count || s->garbage_count || s->p2_left; }

static void relist(bus_monitor_t *mon, uint8_t sender, sender_t *s) {
  const bool want = has_bytes(s);
  if (want && !s->listed) {
    mon->open[mon->open_count++] = sender;
  } else if (!want && s->listed) {
    for (size_t k = 0; k < mon->open_count; k++) {
      if (mon->open[k] == sender) {
        mon->open[k] = mon->open[--mon->open_count];
        break;
      }
    }
  }
  s->listed = want;
}

static void end_partial(bus_monitor_t *mon, uint8_t sender) {
  sender_t *s = mon->senders[sender];
  scan(mon, sender, s, true);
  relist(mon, sender, s);
}

void bus_monitor_byte(void *ctx, const bus_tap_byte_t *byte) {
  bus_monitor_t *mon = ctx;
  /* Backwards: end_partial moves the last entry into the slot it frees, one already seen. A
   * collided byte ends nothing: senders in lockstep (replies to a broadcast PING) start each
   * byte as the other's previous one ends. */
  for (size_t k = mon->open_count; k-- > 0 && !(byte->flags & BUS_RX_COLLISION);) {
    const uint8_t other = mon->open[k];
    if (other != byte->sender && mon->senders[other]->last_end <= byte->start) {
      end_partial(mon, other); /* it stopped, this sender took the wire */
    }
  }
  sender_t *s = mon->senders[byte->sender];
  if (!s) {
    s = mon->senders[byte->sender] = calloc(1, sizeof(*s));
    if (!s) {
      mon->dropped_bytes++;
      return;
    }
  }
  if (has_bytes(s) && byte->start > s->last_end + mon->gap) {
    end_partial(mon, byte->sender);
  }
  s->last_end = byte->end;
  if (s->candidate_count == BUS_MONITOR_MAX_RAW) {
    first_to_garbage(mon, byte->sender, s); /* a header of hundreds of FF bytes: never a packet */
  }
  const mon_byte_t b = {.start = byte->start,
                        .end = byte->end,
                        .value = byte->sent,
                        .flags = byte->flags,
                        .noise = byte->wire != byte->sent || (byte->flags & BUS_RX_FRAMING_ERROR)};
  s->candidate[s->candidate_count++] = b;
  if (s->p2_left) {
    if (--s->p2_left == 0 || s->candidate_count == BUS_MONITOR_MAX_RAW) {
      report(mon, byte->sender, BUS_PACKET_PROTOCOL2, s->candidate, s->candidate_count);
      s->candidate_count = 0;
    }
  } else {
    scan(mon, byte->sender, s, false);
  }
  relist(mon, byte->sender, s);
}

void bus_monitor_flush(bus_monitor_t *mon, sim_cycles_t now) {
  for (size_t k = mon->open_count; k-- > 0;) {
    const uint8_t sender = mon->open[k];
    if (now > mon->senders[sender]->last_end + mon->gap) {
      end_partial(mon, sender);
    }
  }
}

void bus_monitor_finish(bus_monitor_t *mon) {
  while (mon->open_count) {
    end_partial(mon, mon->open[mon->open_count - 1u]);
  }
}
