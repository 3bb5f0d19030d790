/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The bus monitor's packets for the control socket's subscribers (docs/dashboard.md), as
 * batches of JSON objects: {"event":"packets","packets":[...],"dropped":N} at most
 * EMU_PACKET_STREAM_PERIOD_US apart (wall clock), so a busy bus (thousands of packets a
 * second) costs one line per batch.
 *
 * It listens to --log-bus's monitor when there is one, else to a monitor of its own that exists
 * only while someone subscribes: with no subscriber the bus has no tap. */
#ifndef EMU_PACKET_STREAM_H
#define EMU_PACKET_STREAM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "bus_monitor.h"

#define EMU_PACKET_STREAM_BATCH_MAX 4000u
#define EMU_PACKET_STREAM_PERIOD_US 50000.0

typedef struct {
  bus_t *bus;
  bus_monitor_t **shared; /* --log-bus's monitor (may be NULL) */
  bus_monitor_t *own;
  int listener;           /* -1: not listening */
  int client_node, master_node;
  void *batch;            /* cJSON array, NULL when empty */
  size_t batch_count;
  uint64_t dropped;       /* past EMU_PACKET_STREAM_BATCH_MAX in one batch */
  double due_us;
} emu_packet_stream_t;

/* client_node: the pty's; master_node: the second master's (its packets are instructions). */
void emu_packet_stream_init(emu_packet_stream_t *s, bus_t *bus, bus_monitor_t **shared, int client_node,
                            int master_node);

/* Listens while wanted, else stops (removing its own monitor). */
void emu_packet_stream_want(emu_packet_stream_t *s, bool wanted);

/* The next batch's line (malloc'd, the caller frees it) when one is due at wall_us, else NULL.
 * now: the world's time, for partial packets past the gap. */
char *emu_packet_stream_take(emu_packet_stream_t *s, double wall_us, sim_cycles_t now);

void emu_packet_stream_close(emu_packet_stream_t *s);

#endif
