/* SPDX-License-Identifier: MIT */
/* The Dynamixel bus: one half-duplex, multi-drop wire shared by every node (servos, the test
 * master, the pty bridge). Pure C, no simavr: nodes tell the bus when they start a byte and
 * receive finished bytes through a callback.
 *
 * Timing: a byte occupies the wire from the start of its start bit (`start`) to the end of
 * its stop bit (`end`), frame_bits x the sender's bit time (10 for 8N1). Every other node
 * receives it at `end`. Timestamps are absolute cycles (sim_time.h), exact, not quantised.
 *
 * Faults, all deterministic:
 * - baud mismatch: a receiver whose bit time differs from the sender's by more than
 *   BUS_BAUD_TOLERANCE decodes the waveform by sampling it at its own bit centres; the
 *   result is forced to differ from what was sent, so such a link never communicates.
 * - collision: bytes of two senders whose active parts (start bit to the middle of the stop
 *   bit) overlap are both marked; the line is modelled as wired-AND (a driven 0 wins) and a
 *   receiver decodes that combined waveform, one frame per overlapping group.
 * - truncation: a sender that stops driving (direction pin released) in the middle of a
 *   byte leaves the line idle (1) from then on; receivers decode what was on the wire.
 * - noise (bus_set_noise, off by default): each bit of a frame flips with a set probability,
 *   drawn once per byte when it is finalized, so every receiver gets the same corrupted
 *   byte. A flipped data bit changes the value; a flipped start or stop bit is delivered as
 *   BUS_RX_FRAMING_ERROR with the data bits as sampled (the model does not re-synchronise a
 *   receiver on a later edge, so such a flip never disturbs the following byte).
 *
 * Scheduling contract (see world.c): the bus "finalizes" a byte (decides what each node
 * receives and calls its deliver callback) once the world's clock has reached
 * end - BUS_FINALIZE_MARGIN; by then every byte that can disturb it has started, because a
 * node starts a byte at the moment it writes it. Nodes deliver at `end` exactly.
 */
#ifndef SIM_BUS_H
#define SIM_BUS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "bus_noise.h"
#include "sim_time.h"

#define BUS_MAX_NODES 256
#define BUS_FRAME_BITS_8N1 10u
#define BUS_BAUD_TOLERANCE 0.03
/* Cycles before a byte's end at which it is finalized; larger than the longest overshoot
 * of an AVR past a run boundary (one instruction plus an interrupt entry). */
#define BUS_FINALIZE_MARGIN 8u

enum {
  BUS_RX_COLLISION = 1u << 0,     /* another sender overlapped this byte */
  BUS_RX_BAUD_MISMATCH = 1u << 1, /* receiver and sender bauds differ by > 3 % */
  BUS_RX_TRUNCATED = 1u << 2,     /* the sender stopped driving before the stop bit */
  BUS_RX_FRAMING_ERROR = 1u << 3, /* noise flipped the start or the stop bit */
};

/* One byte as one receiver gets it. */
typedef struct {
  sim_cycles_t start; /* start of the start bit on the wire */
  sim_cycles_t end;   /* end of the stop bit: the moment of delivery */
  uint8_t value;      /* as this receiver decoded it */
  uint8_t sent;       /* as the sender sent it */
  uint8_t flags;      /* BUS_RX_* */
  uint8_t sender;     /* node index */
} bus_rx_t;

typedef struct {
  /* The node's UART bit time now, in cycles (16 at 1 Mbps). */
  double (*cycles_per_bit)(void *ctx);
  /* A byte this node receives at rx->end. Called ahead of time (see the scheduling
   * contract); the node must make it visible at rx->end, not before. */
  void (*deliver)(void *ctx, const bus_rx_t *rx);
  void *ctx;
} bus_node_ops_t;

typedef struct {
  sim_cycles_t start, end;
  sim_cycles_t cut_at; /* SIM_CYCLES_NEVER unless truncated */
  double cycles_per_bit;
  uint8_t value;
  uint8_t frame_bits;
  uint8_t flags;
  uint8_t sender;
} bus_byte_t;

/* One byte as the bus finalized it, as a tap sees it (bus_set_tap): what its sender sent,
 * where it was on the wire and what happened to it there. Receivers may still decode another
 * value (a collision, a baud mismatch, a cut byte: bus_rx_t). */
typedef struct {
  sim_cycles_t start; /* start of the start bit on the wire */
  sim_cycles_t end;   /* end of the stop bit */
  uint8_t sent;       /* as the sender sent it */
  uint8_t wire;       /* after the line's noise (== sent without noise) */
  uint8_t flags;      /* BUS_RX_COLLISION, BUS_RX_TRUNCATED, BUS_RX_FRAMING_ERROR */
  uint8_t sender;     /* node index */
} bus_tap_byte_t;

/* Called once for every byte the bus finalizes, in the order of their ends, on the thread
 * that runs bus_finalize (the world's main thread), after the byte's collisions are known and
 * before it is delivered. It must not call back into the bus. */
typedef void (*bus_tap_fn)(void *ctx, const bus_tap_byte_t *byte);

#define BUS_HISTORY 16u

typedef struct {
  bool used;
  char name[24];
  bus_node_ops_t ops;
  /* Bytes this node has started and the bus has not finalized, in order. */
  bus_byte_t *pending;
  size_t pending_cap, pending_head, pending_count;
  /* The last finalized bytes (for collisions with bytes that end later). */
  bus_byte_t history[BUS_HISTORY];
  size_t history_count; /* total ever pushed; index = count % BUS_HISTORY */
  sim_cycles_t tx_end;  /* end of the last byte this node queued */
  sim_cycles_t rx_busy_until;
  /* Statistics. */
  uint64_t tx_bytes;
  uint64_t rx_bytes;
} bus_node_t;

typedef struct {
  bus_node_t nodes[BUS_MAX_NODES];
  size_t node_count;
  sim_cycles_t lookahead; /* cached bus_lookahead(); 0 = recompute */
  size_t pending_total;   /* bytes started and not finalized, over all nodes */
  uint64_t collided_bytes;
  uint64_t mismatched_deliveries;
  uint64_t truncated_bytes;
  bus_noise_t noise;
  uint64_t noise_corrupted_bytes; /* bytes with at least one flipped bit */
  uint64_t noise_flipped_bits;
  bus_tap_fn tap; /* NULL: no tap, nothing done per byte */
  void *tap_ctx;
} bus_t;

void bus_init(bus_t *bus);
void bus_free(bus_t *bus);

/* Adds a node; returns its index, or -1 when the bus is full. */
int bus_add_node(bus_t *bus, const char *name, const bus_node_ops_t *ops);

/* Replaces the deliver callback of node (its ctx stays): call between world steps. */
void bus_set_node_deliver(bus_t *bus, int node, void (*deliver)(void *ctx, const bus_rx_t *rx));

/* Noise on the wire from now on: every bit of every byte finalized later flips with
 * probability bit_error_rate, from a PRNG seeded with seed (bus_noise.h). Rate 0 (the state
 * after bus_init) is no noise and no PRNG draws. Returns false, leaving the noise off, for a
 * rate outside [0, 1). Call it between world steps (the main thread finalizes). */
bool bus_set_noise(bus_t *bus, double bit_error_rate, uint64_t seed);

/* Offers every byte finalized from now on to tap (NULL removes it; one tap at a time: a
 * bus monitor fans its packets out to several listeners). Call it between world steps. */
void bus_set_tap(bus_t *bus, bus_tap_fn tap, void *ctx);

/* Node `node` puts a byte on the wire starting at `start` (or when its previous byte ends,
 * if later) at its current bit time. Returns the end of the byte's stop bit. */
sim_cycles_t bus_send(bus_t *bus, int node, uint8_t value, sim_cycles_t start);

/* Node `node` stops driving the wire at `at`: its bytes not yet started are dropped, a byte
 * in progress keeps what was on the wire before `at`. */
void bus_release(bus_t *bus, int node, sim_cycles_t at);

/* The earliest time at which a pending byte becomes final (end - margin), or
 * SIM_CYCLES_NEVER. */
sim_cycles_t bus_next_finalize(const bus_t *bus);

/* The earliest start among the bytes not yet finalized, or SIM_CYCLES_NEVER: no delivery
 * made later concerns a moment before it (a trace commits what lies before it). */
sim_cycles_t bus_first_pending_start(const bus_t *bus);

/* A node's bit time changed (it must call this whenever its cycles_per_bit() would return
 * something new). */
void bus_baud_changed(bus_t *bus);

/* The longest step the world may take without a byte that starts inside it ending (minus
 * the margin) inside it: the shortest frame of any node, minus the margin. */
sim_cycles_t bus_lookahead(bus_t *bus);

/* Finalizes every byte with end - margin <= now, in order of their ends, and delivers it. */
void bus_finalize(bus_t *bus, sim_cycles_t now);

/* What a receiver with bit time rx_cycles_per_bit decodes when it sees the bytes in group
 * (wired-AND) with its frame starting at frame_start. Exposed for tests. */
uint8_t bus_decode(const bus_byte_t *group, size_t count, sim_cycles_t frame_start, double rx_cycles_per_bit);

#endif
