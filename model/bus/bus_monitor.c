/* SPDX-License-Identifier: MIT */
#include "bus_monitor.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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
    unsigned sum = 0;
    for (size_t i = h; i + 1u < count; i++) {
      sum += raw[i];
    }
    p.checksum_ok = (uint8_t)(~sum & 0xFFu) == p.checksum;
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

/* ---- names and CSV ---- */

const char *bus_packet_instruction_name(uint8_t instruction) {
  switch (instruction) {
  case 0x01:
    return "PING";
  case 0x02:
    return "READ";
  case 0x03:
    return "WRITE";
  case 0x04:
    return "REG_WRITE";
  case 0x05:
    return "ACTION";
  case 0x06:
    return "RESET";
  case 0x83:
    return "SYNC_WRITE";
  default:
    return NULL;
  }
}

const char *bus_packet_kind_name(bus_packet_kind_t kind) {
  switch (kind) {
  case BUS_PACKET_INSTRUCTION:
    return "instruction";
  case BUS_PACKET_STATUS:
    return "status";
  case BUS_PACKET_GARBAGE:
    return "garbage";
  case BUS_PACKET_PROTOCOL2:
    return "protocol2";
  }
  return "?";
}

const char *bus_packet_error_names(uint8_t error, char *text, size_t text_len) {
  /* The manual's error bits, bit 0 first. */
  static const char *const names[8] = {"VOLTAGE",  "ANGLE_LIMIT", "OVERHEATING", "RANGE",
                                       "CHECKSUM", "OVERLOAD",    "INSTRUCTION", "BIT7"};
  size_t used = 0;
  text[0] = '\0';
  if (error == 0) {
    snprintf(text, text_len, "NONE");
    return text;
  }
  for (unsigned bit = 0; bit < 8; bit++) {
    if ((error >> bit) & 1u) {
      const int n = snprintf(text + used, text_len - used, "%s%s", used ? "|" : "", names[bit]);
      if (n < 0 || (size_t)n >= text_len - used) {
        text[used] = '\0'; /* whole names only */
        break;
      }
      used += (size_t)n;
    }
  }
  return text;
}

typedef struct {
  char *out;
  size_t len, used;
} line_t;

static void put(line_t *l, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(line_t *l, const char *fmt, ...) {
  if (l->used + 1u >= l->len) {
    return;
  }
  va_list ap;
  va_start(ap, fmt);
  const int n = vsnprintf(l->out + l->used, l->len - l->used, fmt, ap);
  va_end(ap);
  if (n > 0) {
    l->used += (size_t)n < l->len - l->used ? (size_t)n : l->len - l->used - 1u;
  }
}

static void put_hex(line_t *l, const uint8_t *bytes, size_t count) {
  static const char digits[] = "0123456789ABCDEF";
  for (size_t i = 0; i < count && l->used + 4u < l->len; i++) {
    if (i) {
      l->out[l->used++] = ' ';
    }
    l->out[l->used++] = digits[bytes[i] >> 4];
    l->out[l->used++] = digits[bytes[i] & 0xFu];
  }
  l->out[l->used] = '\0';
}

/* Cycles as microseconds with four decimals, exactly (a cycle is 0.0625 us), and a comma. */
static void put_us(line_t *l, sim_cycles_t cycles) {
  _Static_assert(SIM_CYCLES_PER_US == 16u, "four decimals hold a cycle exactly");
  put(l, "%llu.%04u,", (unsigned long long)(cycles / SIM_CYCLES_PER_US),
      (unsigned)(cycles % SIM_CYCLES_PER_US) * 625u);
}

/* A name as a CSV field: no quoting needed once separators are replaced. */
static void put_name(line_t *l, const char *name) {
  for (const char *c = name; *c && l->used + 1u < l->len; c++) {
    l->out[l->used++] = (*c == ',' || *c == '"' || *c == '\n' || *c == '\r') ? '_' : *c;
  }
  l->out[l->used] = '\0';
}

size_t bus_packet_csv(const bus_packet_t *p, char *out, size_t out_len) {
  line_t l = {.out = out, .len = out_len, .used = 0};
  if (out_len == 0) {
    return 0;
  }
  out[0] = '\0';
  put_us(&l, p->start);
  put_us(&l, p->end);
  put_name(&l, p->sender_name ? p->sender_name : "");
  put(&l, ",%s,", bus_packet_kind_name(p->kind));
  const bool framed = p->kind == BUS_PACKET_INSTRUCTION || p->kind == BUS_PACKET_STATUS;
  if (framed) {
    char names[BUS_PACKET_ERROR_NAMES_MAX];
    const char *name = p->kind == BUS_PACKET_INSTRUCTION ? bus_packet_instruction_name(p->code)
                                                         : bus_packet_error_names(p->code, names, sizeof(names));
    put(&l, "%u,0x%02X,%s,", p->id, p->code, name ? name : "UNKNOWN");
    put_hex(&l, p->params, p->param_count);
    put(&l, ",%d,", p->checksum_ok ? 1 : 0);
  } else {
    put(&l, ",,,,,");
  }
  put(&l, "%d,%s%s%s,", p->collision ? 1 : 0, (p->line_flags & BUS_RX_TRUNCATED) ? "truncated" : "",
      (p->line_flags & BUS_RX_TRUNCATED) && p->noise_changed ? "|" : "", p->noise_changed ? "noise" : "");
  put_hex(&l, p->raw, p->raw_count);
  put(&l, "\n");
  return l.used;
}
