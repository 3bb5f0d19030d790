/* SPDX-License-Identifier: MIT */
#include "bus_monitor.h"

#include <stdlib.h>
#include <string.h>

#include "dxl_frame.h"
#include "packet_encode.h"

/* Protocol 1.0 as the manual gives it (the raw bytes of a record are read here apart from the
 * firmware's code; the framing is the one rule every reader follows, dxl_frame.h). */
#define HEADER_BYTE 0xFFu
#define SHORTEST_LENGTH 2u /* LENGTH of a packet with no parameters: code + checksum */
/* Header bytes held at most (two 0xFF and the further ones, then the ID): a record keeps room
 * for the ID, the LENGTH and 255 bytes after them; further 0xFF beyond it are garbage. */
#define HEADER_HELD_MAX (BUS_MONITOR_MAX_RAW - 2u - 255u)

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
  dxl_frame_t frame;                    /* the framing step's state of this sender's bytes */
  mon_byte_t held[BUS_MONITOR_MAX_RAW]; /* the header, packet or 2.0 frame under way */
  size_t held_count;
  mon_byte_t garbage[BUS_MONITOR_MAX_RAW]; /* the garbage before them */
  size_t garbage_count;
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

static void add_garbage(bus_monitor_t *mon, uint8_t sender, sender_t *s, const mon_byte_t *b) {
  if (s->garbage_count == BUS_MONITOR_MAX_RAW) {
    report_garbage(mon, sender, s);
  }
  s->garbage[s->garbage_count++] = *b;
}

/* The held bytes were no packet: garbage. */
static void held_to_garbage(bus_monitor_t *mon, uint8_t sender, sender_t *s) {
  for (size_t i = 0; i < s->held_count; i++) {
    add_garbage(mon, sender, s, &s->held[i]);
  }
  s->held_count = 0;
}

/* The held bytes as one record (the garbage before them first). */
static void report_held(bus_monitor_t *mon, uint8_t sender, sender_t *s, bus_packet_kind_t kind) {
  report_garbage(mon, sender, s);
  report(mon, sender, kind, s->held, s->held_count);
  s->held_count = 0;
}

/* ---- framing: the step every reader runs, dxl_frame.h ---- */

static void frame_byte(bus_monitor_t *mon, uint8_t sender, sender_t *s, const mon_byte_t *b) {
  switch (dxl_frame_step(&s->frame, b->value)) {
  case DXL_BYTE_GARBAGE: /* and the header it ended, if any */
    held_to_garbage(mon, sender, s);
    add_garbage(mon, sender, s, b);
    break;
  case DXL_BYTE_HEADER:
    if (s->held_count == HEADER_HELD_MAX) { /* a header of hundreds of 0xFF: the first are garbage */
      add_garbage(mon, sender, s, &s->held[0]);
      memmove(s->held, s->held + 1, (s->held_count - 1u) * sizeof(mon_byte_t));
      s->held_count--;
    }
    s->held[s->held_count++] = *b;
    break;
  case DXL_BYTE_LENGTH:
  case DXL_BYTE_BODY:
    s->held[s->held_count++] = *b;
    break;
  case DXL_BYTE_CHECKSUM:
  case DXL_BYTE_CHECKSUM_BAD:
    s->held[s->held_count++] = *b;
    report_held(mon, sender, s, sends_instructions(mon, sender) ? BUS_PACKET_INSTRUCTION : BUS_PACKET_STATUS);
    break;
  default: /* DXL_BYTE_PROTOCOL2: reported when it ends, a long one in several records */
    s->held[s->held_count++] = *b;
    if (s->frame.state == DXL_FRAME_SEARCH || s->held_count == BUS_MONITOR_MAX_RAW) {
      report_held(mon, sender, s, BUS_PACKET_PROTOCOL2);
    }
    break;
  }
}

/* Nothing more comes from this sender for what it has under way (gap, another sender,
 * finish): a 2.0 frame is reported as far as it came, anything else held is garbage, and the
 * next byte starts a search. */
static void end_under_way(bus_monitor_t *mon, uint8_t sender, sender_t *s) {
  if (s->frame.state >= DXL_FRAME_P2_ID && s->held_count != 0) {
    report_held(mon, sender, s, BUS_PACKET_PROTOCOL2);
  }
  held_to_garbage(mon, sender, s);
  report_garbage(mon, sender, s);
  dxl_frame_reset(&s->frame);
}

/* ---- senders with bytes not reported ---- */

static bool has_bytes(const sender_t *s) {
  return s->held_count || s->garbage_count || s->frame.state != DXL_FRAME_SEARCH;
}

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
  end_under_way(mon, sender, s);
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
  const mon_byte_t b = {.start = byte->start,
                        .end = byte->end,
                        .value = byte->sent,
                        .flags = byte->flags,
                        .noise = byte->wire != byte->sent || (byte->flags & BUS_RX_FRAMING_ERROR)};
  frame_byte(mon, byte->sender, s, &b);
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
