/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Packets onto the bus from a second master (the control socket's "send": the dashboard's
 * edits), beside the client on the pty (docs/dashboard.md "Edits travel as packets").
 *
 * While a packet is queued the pty bridge holds the client (pty_bridge_hold: its next bytes
 * wait); the packet goes on the wire once nothing has moved on the bus for
 * EMU_BUS_MASTER_IDLE_US (a servo still answering the client, even late, has answered), at the
 * baud of the servo it addresses, and the client is shown nothing of the exchange
 * (pty_bridge_hide). The reply is over when a whole status packet has come,
 * EMU_BUS_MASTER_GAP_BYTES byte times after its last byte, or EMU_BUS_MASTER_WAIT_US plus
 * that after the request when none came. Then the client goes on. */
#ifndef EMU_BUS_MASTER_H
#define EMU_BUS_MASTER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "master.h"
#include "pty_bridge.h"
#include "servo_probe.h"
#include "world.h"

#define EMU_BUS_MASTER_QUEUE 16u
#define EMU_BUS_MASTER_PACKET_MAX 256u
#define EMU_BUS_MASTER_IDLE_US 1500u
#define EMU_BUS_MASTER_GAP_BYTES 10u
#define EMU_BUS_MASTER_WAIT_US 1500u
/* While a packet is queued or on the wire, the world is stepped at most this far between polls. */
#define EMU_BUS_MASTER_POLL_US 50u

typedef struct {
  unsigned token; /* the caller's: who asked */
  uint8_t bytes[EMU_BUS_MASTER_PACKET_MAX];
  size_t len;
} emu_bus_master_job_t;

/* A finished exchange: the reply's bytes (count 0: none came), at the world's time. */
typedef void (*emu_bus_master_done_fn)(void *ctx, unsigned token, const uint8_t *reply, size_t count);

typedef struct {
  world_t *world;
  pty_bridge_t *pty;
  const servo_probe_map_t *map; /* to read the addressed servo's baud */
  master_t *master;
  emu_bus_master_job_t queue[EMU_BUS_MASTER_QUEUE];
  size_t queue_head, queue_count;
  bool sending; /* queue[queue_head] is on the wire or awaiting its reply */
  sim_cycles_t request_end;
} emu_bus_master_t;

/* Adds the master node to the world's bus, named "control", at the client's baud. -1 when the
 * bus is full. */
int emu_bus_master_open(emu_bus_master_t *m, world_t *world, pty_bridge_t *pty, const servo_probe_map_t *map);

/* Lets the client go if an exchange was under way (at exit). */
void emu_bus_master_close(emu_bus_master_t *m);

/* Queues a packet; false when EMU_BUS_MASTER_QUEUE are waiting. */
bool emu_bus_master_queue(emu_bus_master_t *m, unsigned token, const uint8_t *bytes, size_t len);

/* Between world steps: starts the next packet when the bus allows, reports a finished one. */
void emu_bus_master_poll(emu_bus_master_t *m, emu_bus_master_done_fn done, void *ctx);

/* True while a packet waits or is on the wire. */
bool emu_bus_master_busy(const emu_bus_master_t *m);

/* The master hears every byte on the bus: drop what it heard while idle. */
void emu_bus_master_forget(emu_bus_master_t *m);

#endif
