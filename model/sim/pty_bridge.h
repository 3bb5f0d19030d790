/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The bridge between the simulated bus and client software: a pseudo-terminal that clients
 * open as a serial port (a USB2Dynamixel stand-in). Single-threaded, pumped by the serve
 * loop.
 *
 * - The client's baud is what it set on the pty, read on the master side with TCGETS2
 *   (c_ospeed) at every pump. The bus garbles traffic when it differs from a servo's by more
 *   than 3 %, as the real bus does.
 * - Bytes the client writes enter the wire at the world's time when the bridge reads them,
 *   back to back at 10 bit times each (the adapter's UART).
 * - Bytes the servos send are written to the pty when their stop bit has ended on the wire
 *   (simulated time). The client never sees its own bytes (the adapter's receiver is off
 *   while it transmits).
 * A slave fd stays open in the bridge, so the master never reads EIO when a client closes. */
#ifndef SIM_PTY_BRIDGE_H
#define SIM_PTY_BRIDGE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "bus.h"
#include "world.h"

/* Client bytes not yet on the wire beyond which the bridge stops reading (the pty buffers). */
#define PTY_BRIDGE_MAX_QUEUED 4096u

typedef struct {
  sim_cycles_t end;
  uint8_t value;
} pty_out_byte_t;

typedef struct {
  world_t *world;
  int node;
  int master_fd;
  int slave_fd;
  char device[128];
  char link_path[4096];
  bool linked;
  double bps;
  double cycles_per_bit;
  pty_out_byte_t *out;
  size_t out_head, out_count, out_cap;
  sim_cycles_t last_from_client_end;
  uint64_t from_client;
  uint64_t to_client;
  uint64_t dropped_to_client; /* the client did not read and the pty buffer was full */
} pty_bridge_t;

/* Opens the pty (raw, initial speed initial_bps) and joins the bus; creates link_path (a
 * symlink to the device) when not NULL, replacing an existing symlink. -1 with err set. */
int pty_bridge_open(pty_bridge_t *pty, world_t *world, double initial_bps, const char *link_path, char *err,
                    size_t err_len);
void pty_bridge_close(pty_bridge_t *pty);

/* Writes every byte whose stop bit has ended by the world's time, then reads what the client
 * wrote and puts it on the wire from the world's time. Returns true if a byte moved. */
bool pty_bridge_pump(pty_bridge_t *pty);

#endif
