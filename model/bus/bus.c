/* SPDX-License-Identifier: MIT */
#include "bus.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

_Static_assert(BUS_NOISE_FRAME_BITS == BUS_FRAME_BITS_8N1, "the noise model's frame is the wire's frame");

void bus_init(bus_t *bus) { memset(bus, 0, sizeof(*bus)); }

bool bus_set_noise(bus_t *bus, double bit_error_rate, uint64_t seed) {
  return bus_noise_init(&bus->noise, bit_error_rate, seed);
}

void bus_set_tap(bus_t *bus, bus_tap_fn tap, void *ctx) {
  bus->tap = tap;
  bus->tap_ctx = ctx;
}

void bus_free(bus_t *bus) {
  for (size_t i = 0; i < bus->node_count; i++) {
    free(bus->nodes[i].pending);
  }
  memset(bus, 0, sizeof(*bus));
}

int bus_add_node(bus_t *bus, const char *name, const bus_node_ops_t *ops) {
  if (bus->node_count >= BUS_MAX_NODES) {
    return -1;
  }
  bus_node_t *n = &bus->nodes[bus->node_count];
  memset(n, 0, sizeof(*n));
  n->used = true;
  strncpy(n->name, name ? name : "node", sizeof(n->name) - 1);
  n->ops = *ops;
  bus->lookahead = 0;
  return (int)bus->node_count++;
}

static double node_cycles_per_bit(const bus_node_t *n) {
  const double cpb = n->ops.cycles_per_bit(n->ops.ctx);
  return cpb > 0.0 ? cpb : 16.0;
}

static bus_byte_t *pending_at(bus_node_t *n, size_t i) {
  return &n->pending[(n->pending_head + i) % n->pending_cap];
}

static const bus_byte_t *pending_at_const(const bus_node_t *n, size_t i) {
  return &n->pending[(n->pending_head + i) % n->pending_cap];
}

static void pending_push(bus_node_t *n, const bus_byte_t *b) {
  if (n->pending_count == n->pending_cap) {
    const size_t cap = n->pending_cap ? n->pending_cap * 2u : 64u;
    bus_byte_t *grown = malloc(cap * sizeof(*grown));
    if (!grown) {
      abort();
    }
    for (size_t i = 0; i < n->pending_count; i++) {
      grown[i] = *pending_at(n, i);
    }
    free(n->pending);
    n->pending = grown;
    n->pending_cap = cap;
    n->pending_head = 0;
  }
  n->pending[(n->pending_head + n->pending_count) % n->pending_cap] = *b;
  n->pending_count++;
}


static void pending_pop(bus_node_t *n) {
  n->pending_head = (n->pending_head + 1u) % n->pending_cap;
  n->pending_count--;
}

sim_cycles_t bus_send(bus_t *bus, int node, uint8_t value, sim_cycles_t start) {
  bus_node_t *n = &bus->nodes[node];
  bus_byte_t b;
  memset(&b, 0, sizeof(b));
  b.cycles_per_bit = node_cycles_per_bit(n);
  b.frame_bits = BUS_FRAME_BITS_8N1;
  b.start = start > n->tx_end ? start : n->tx_end;
  b.end = b.start + (sim_cycles_t)llround(b.cycles_per_bit * b.frame_bits);
  b.cut_at = SIM_CYCLES_NEVER;
  b.value = value;
  b.sender = (uint8_t)node;
  n->tx_end = b.end;
  n->tx_bytes++;
  pending_push(n, &b);
  __atomic_add_fetch(&bus->pending_total, 1u, __ATOMIC_RELAXED); /* senders may run on two threads */
  return b.end;
}

/* The part of a byte that can disturb or be disturbed: start bit to the middle of the stop
 * bit (a receiver has sampled the stop bit by then). */
static sim_cycles_t active_end(const bus_byte_t *b) {
  return b->end - (sim_cycles_t)(b->cycles_per_bit / 2.0);
}

void bus_release(bus_t *bus, int node, sim_cycles_t at) {
  bus_node_t *n = &bus->nodes[node];
  size_t keep = 0;
  for (size_t i = 0; i < n->pending_count; i++) {
    bus_byte_t *b = pending_at(n, i);
    if (b->start >= at) {
      break; /* never driven: this and every later byte are dropped */
    }
    if (active_end(b) > at && b->cut_at == SIM_CYCLES_NEVER) {
      b->cut_at = at;
      b->flags |= BUS_RX_TRUNCATED;
      __atomic_add_fetch(&bus->truncated_bytes, 1u, __ATOMIC_RELAXED);
    }
    keep++;
  }
  __atomic_sub_fetch(&bus->pending_total, n->pending_count - keep, __ATOMIC_RELAXED);
  n->pending_count = keep;
  n->tx_end = keep ? pending_at(n, keep - 1u)->end : (n->tx_end < at ? n->tx_end : at);
}

sim_cycles_t bus_next_finalize(const bus_t *bus) {
  sim_cycles_t next = SIM_CYCLES_NEVER;
  if (!bus->pending_total) {
    return next;
  }
  for (size_t i = 0; i < bus->node_count; i++) {
    const bus_node_t *n = &bus->nodes[i];
    if (n->pending_count) {
      const sim_cycles_t t = pending_at_const(n, 0)->end - BUS_FINALIZE_MARGIN;
      if (t < next) {
        next = t;
      }
    }
  }
  return next;
}

void bus_set_node_deliver(bus_t *bus, int node, void (*deliver)(void *ctx, const bus_rx_t *rx)) {
  if (node >= 0 && (size_t)node < bus->node_count) {
    bus->nodes[node].ops.deliver = deliver;
  }
}

sim_cycles_t bus_first_pending_start(const bus_t *bus) {
  sim_cycles_t first = SIM_CYCLES_NEVER;
  if (!bus->pending_total) {
    return first;
  }
  for (size_t i = 0; i < bus->node_count; i++) {
    const bus_node_t *n = &bus->nodes[i];
    if (n->pending_count && pending_at_const(n, 0)->start < first) {
      first = pending_at_const(n, 0)->start;
    }
  }
  return first;
}

void bus_baud_changed(bus_t *bus) { __atomic_store_n(&bus->lookahead, 0u, __ATOMIC_RELAXED); }

sim_cycles_t bus_lookahead(bus_t *bus) {
  if (bus->lookahead) {
    return bus->lookahead;
  }
  double shortest = 1e18;
  for (size_t i = 0; i < bus->node_count; i++) {
    const double frame = node_cycles_per_bit(&bus->nodes[i]) * BUS_FRAME_BITS_8N1;
    if (frame < shortest) {
      shortest = frame;
    }
  }
  if (bus->node_count == 0) {
    shortest = 160.0;
  }
  const double step = floor(shortest) - 2.0 * BUS_FINALIZE_MARGIN;
  bus->lookahead = step < 8.0 ? 8u : (sim_cycles_t)step;
  return bus->lookahead;
}

/* The level a byte drives at time t (1 = idle/mark). */
static int byte_level(const bus_byte_t *b, double t) {
  if (t < (double)b->start || t >= (double)b->end || t >= (double)b->cut_at) {
    return 1;
  }
  const unsigned bit = (unsigned)((t - (double)b->start) / b->cycles_per_bit);
  if (bit == 0) {
    return 0; /* start bit */
  }
  if (bit <= 8) {
    return (b->value >> (bit - 1u)) & 1;
  }
  return 1; /* stop bit */
}

uint8_t bus_decode(const bus_byte_t *group, size_t count, sim_cycles_t frame_start, double rx_cycles_per_bit) {
  uint8_t v = 0;
  for (unsigned i = 0; i < 8; i++) {
    const double t = (double)frame_start + (1.5 + i) * rx_cycles_per_bit;
    int level = 1;
    for (size_t k = 0; k < count; k++) {
      level &= byte_level(&group[k], t);
    }
    v |= (uint8_t)(level << i);
  }
  return v;
}

static bool overlaps(const bus_byte_t *a, const bus_byte_t *b) {
  return a->start < active_end(b) && b->start < active_end(a);
}

#define GROUP_MAX 64u

/* Collects into group[] the bytes of other senders that overlap x (x itself first). */
static size_t collect_overlaps(bus_t *bus, bus_byte_t *x, bus_byte_t *group) {
  size_t count = 0;
  group[count++] = *x;
  for (size_t i = 0; i < bus->node_count; i++) {
    if (i == x->sender) {
      continue;
    }
    bus_node_t *n = &bus->nodes[i];
    const size_t hist = n->history_count < BUS_HISTORY ? n->history_count : BUS_HISTORY;
    for (size_t h = 0; h < hist; h++) {
      bus_byte_t *y = &n->history[(n->history_count - 1u - h) % BUS_HISTORY];
      if (active_end(y) <= x->start) {
        break; /* newest first: the older ones ended earlier still */
      }
      if (overlaps(x, y)) {
        y->flags |= BUS_RX_COLLISION;
        if (count < GROUP_MAX) {
          group[count++] = *y;
        }
      }
    }
    for (size_t p = 0; p < n->pending_count; p++) {
      bus_byte_t *y = pending_at(n, p);
      if (y->start >= active_end(x)) {
        break;
      }
      if (overlaps(x, y)) {
        y->flags |= BUS_RX_COLLISION;
        if (count < GROUP_MAX) {
          group[count++] = *y;
        }
      }
    }
  }
  if (count > 1) {
    x->flags |= BUS_RX_COLLISION;
    group[0].flags = x->flags;
  }
  return count;
}

/* The wire's noise on x, drawn once as x is finalized (on the main thread, in order of the
 * bytes' ends, so the draws are deterministic): every receiver, and the decode of any byte
 * that collides with x later, sees the same corrupted frame. */
static void add_noise(bus_t *bus, bus_byte_t *x) {
  const uint16_t flips = bus_noise_next_frame(&bus->noise);
  if (flips == 0u) {
    return;
  }
  x->value ^= bus_noise_data_xor(flips);
  if (bus_noise_framing_error(flips)) {
    x->flags |= BUS_RX_FRAMING_ERROR;
  }
  bus->noise_corrupted_bytes++;
  bus->noise_flipped_bits += (uint64_t)__builtin_popcount(flips);
}

static void finalize_one(bus_t *bus, bus_byte_t x) {
  const uint8_t sent = x.value;
  add_noise(bus, &x);
  bus_byte_t group[GROUP_MAX];
  const size_t count = collect_overlaps(bus, &x, group);
  if (x.flags & BUS_RX_COLLISION) {
    bus->collided_bytes++;
  }
  sim_cycles_t frame_start = x.start;
  for (size_t k = 1; k < count; k++) {
    if (group[k].start < frame_start) {
      frame_start = group[k].start;
    }
  }

  if (bus->tap) {
    const bus_tap_byte_t seen = {
        .start = x.start, .end = x.end, .sent = sent, .wire = x.value, .flags = x.flags, .sender = x.sender};
    bus->tap(bus->tap_ctx, &seen);
  }

  bus_node_t *sender = &bus->nodes[x.sender];
  sender->history[sender->history_count % BUS_HISTORY] = x;
  sender->history_count++;

  for (size_t i = 0; i < bus->node_count; i++) {
    if (i == x.sender) {
      continue;
    }
    bus_node_t *n = &bus->nodes[i];
    const double rx_cpb = node_cycles_per_bit(n);
    if (x.start < n->rx_busy_until) {
      continue; /* still inside a frame it started on an overlapping byte */
    }
    bus_rx_t rx;
    rx.start = x.start;
    rx.end = x.end;
    rx.sent = sent;
    rx.sender = x.sender;
    rx.flags = x.flags;
    const bool mismatch = fabs(rx_cpb - x.cycles_per_bit) > BUS_BAUD_TOLERANCE * x.cycles_per_bit;
    if (mismatch) {
      rx.flags |= BUS_RX_BAUD_MISMATCH;
      bus->mismatched_deliveries++;
    }
    if (mismatch || (x.flags & (BUS_RX_COLLISION | BUS_RX_TRUNCATED))) {
      rx.value = bus_decode(group, count, frame_start, rx_cpb);
      if (mismatch && rx.value == sent) {
        rx.value ^= 0x80u; /* docs/policy.md: a link off by more than 3 % does not communicate */
      }
    } else {
      rx.value = x.value;
    }
    /* Ready for a new start bit after sampling its stop bit (9.5 bits into the frame). */
    n->rx_busy_until = frame_start + (sim_cycles_t)((BUS_FRAME_BITS_8N1 - 0.5) * rx_cpb);
    n->rx_bytes++;
    n->ops.deliver(n->ops.ctx, &rx);
  }
}

void bus_finalize(bus_t *bus, sim_cycles_t now) {
  while (bus->pending_total) {
    /* The pending head with the earliest end among all senders. */
    int best = -1;
    sim_cycles_t best_end = SIM_CYCLES_NEVER;
    for (size_t i = 0; i < bus->node_count; i++) {
      bus_node_t *n = &bus->nodes[i];
      if (n->pending_count) {
        const sim_cycles_t e = pending_at(n, 0)->end;
        if (e < best_end) {
          best_end = e;
          best = (int)i;
        }
      }
    }
    if (best < 0 || best_end - BUS_FINALIZE_MARGIN > now) {
      return;
    }
    bus_node_t *n = &bus->nodes[best];
    const bus_byte_t x = *pending_at(n, 0);
    pending_pop(n);
    __atomic_sub_fetch(&bus->pending_total, 1u, __ATOMIC_RELAXED);
    finalize_one(bus, x);
  }
}
