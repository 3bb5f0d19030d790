/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The bridge between the simulated bus and client software: a pseudo-terminal that clients
 * open as a serial port (a USB2Dynamixel stand-in). Pumped by the serve loop, plus one reader
 * thread that drains the pty master continuously.
 *
 * - The client's baud is what it set on the pty, read on the master side with TCGETS2
 *   (c_ospeed) at every pump. The bus garbles traffic when it differs from a servo's by more
 *   than 3 %, as the real bus does.
 * - Bytes the client writes leave the pty at once: a reader thread blocks in poll()/read() on
 *   the master, stamps each chunk with the wall clock (and the client's baud then) and queues
 *   it for the simulation thread. A USB adapter would have sent them already, so a client's
 *   tcflush(TCOFLUSH) before its next packet (pypot does that) must not find them unread.
 *   The simulation puts a chunk on the wire at the simulated time of its arrival, or at the
 *   adapter's next USB frame start (pty_bridge_pump), never earlier than the world's time,
 *   back to back at 10 bit times each (the adapter's UART).
 * - Bytes the servos send go through the USB adapter model (usb_adapter.h) when their stop
 *   bit has ended on the wire (simulated time), and are written to the pty as the adapter
 *   hands them to the host: one write per USB packet (wire: each byte as its stop bit ends,
 *   the due ones in one write). The client never sees its own bytes (the adapter's receiver
 *   is off while it transmits).
 * - The adapter also decides when a client's write enters the wire (its USB frame), the baud
 *   the bus sees for the client's termios baud (its divisor), and how much a client may
 *   write ahead of the wire before its writes block.
 * A slave fd stays open in the bridge, so the master never reads EIO when a client closes. */
#ifndef SIM_PTY_BRIDGE_H
#define SIM_PTY_BRIDGE_H

#include <pthread.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "bus.h"
#include "delay_histogram.h"
#include "pacing.h"
#include "sim_time.h"
#include "usb_adapter.h"

/* Client bytes not yet on the wire beyond which the bridge stops reading (the pty buffers),
 * with the wire adapter; the others bound it as usb_adapter_tx_queue_limit says. */
#define PTY_BRIDGE_MAX_QUEUED 4096u

typedef struct {
  sim_cycles_t end;
  uint8_t value;
} pty_out_byte_t;

/* Reader thread -> simulation thread: chunks as read, with their wall-clock arrival. */
#define PTY_BRIDGE_INBOX_BYTES 65536u
#define PTY_BRIDGE_INBOX_CHUNKS 1024u

typedef struct {
  double wall_us; /* CLOCK_MONOTONIC (pacing_wall_us) when read() returned */
  double reader_wait_us; /* how long the reader, woken by these bytes, waited for a CPU */
  double bps;     /* the client's baud then (TCGETS2), 0 if unknown */
  uint32_t offset, len; /* bytes in the inbox ring */
  sim_cycles_t entry; /* simulated time of its arrival (set by the simulation thread) */
  sim_cycles_t at; /* ... and when it enters the wire, after the adapter's frame wait */
} pty_in_chunk_t;

typedef struct {
  bus_t *bus;
  const sim_cycles_t *now; /* the world's clock (world_t.now), read-only */
  int node;
  int master_fd;
  int slave_fd;
  char device[128];
  char link_path[4096];
  bool linked;
  double bps;            /* what the client set (termios) */
  double actual_bps;     /* what the adapter's baud generator makes of it: the bus sees this */
  double cycles_per_bit; /* of actual_bps */
  usb_adapter_t adapter;
  pty_out_byte_t *out;
  size_t out_head, out_count, out_cap;
  size_t out_fed; /* out[head .. +out_fed) are in the adapter, not yet sent to the host */
  sim_cycles_t last_from_client_end;
  /* Reader thread. */
  pthread_t reader;
  bool reader_started;
  int stop_pipe[2];  /* the reader polls [0]; close() writes [1] */
  int wake_pipe[2];  /* the reader writes [1] after queueing a chunk; poll [0] to wait */
  pthread_mutex_t lock; /* guards the inbox and stopping */
  pthread_cond_t space; /* the simulation freed room in the inbox */
  bool stopping;
  uint8_t *inbox;       /* PTY_BRIDGE_INBOX_BYTES ring */
  uint32_t inbox_head, inbox_used;
  pty_in_chunk_t chunks[PTY_BRIDGE_INBOX_CHUNKS];
  uint32_t chunk_head, chunk_count; /* chunks[chunk_head .. +chunk_count) are queued */
  uint32_t chunk_stamped;           /* how many of them have `at` set (simulation thread) */
  /* Where the simulation was at its last pump: a lagging simulation maps arrivals from here. */
  double anchor_wall_us;
  sim_cycles_t anchor_sim;
  bool anchored;
  uint64_t from_client;
  uint64_t to_client;
  uint64_t dropped_to_client; /* the client did not read and the pty buffer was full */
  /* Wall-clock delays in real time (docs/emulator.md "Real time on a busy machine"):
   * to_bus_delay: from a client's bytes readable on the master (the reader's wake-up) to
   *   their first bit on the simulated wire, the adapter's modelled frame wait left out, as
   *   the client lives it: the later of the wall time the simulation put them there and the
   *   wall time their simulated entry stands for (a simulation ahead of the clock).
   * to_client_late: how late each hand-over of the adapter (wire: each byte) reaches the pty
   *   against the wall time its simulated time stands for (the simulation's lag then).
   * reader_wait_max_us: the longest the reader, woken by the client's bytes, waited for a CPU
   *   (its run-queue delay, /proc/thread-self/schedstat; part of to_bus_delay). */
  delay_histogram_t to_bus_delay;
  delay_histogram_t to_client_late;
  double reader_wait_max_us;
  /* Another master (the dashboard's packets, emu_bus_master.h) wants or has the bus. */
  bool held;   /* pty_bridge_hold() */
  bool hidden; /* pty_bridge_hide() */
} pty_bridge_t;

/* Opens the pty (raw, initial speed initial_bps) behind the USB adapter `adapter` and joins
 * bus, whose scheduler's clock is *now; creates link_path (a symlink to the device) when not NULL, replacing an existing
 * symlink. -1 with err set. */
int pty_bridge_open(pty_bridge_t *pty, bus_t *bus, const sim_cycles_t *now, double initial_bps,
                    const usb_adapter_config_t *adapter, const char *link_path, char *err, size_t err_len);
void pty_bridge_close(pty_bridge_t *pty);

/* Writes every byte whose stop bit has ended by the world's time, then puts the client's
 * queued chunks on the wire whose arrival time has come. A chunk that arrived at wall time w
 * enters at max(now, S(w)): S(w) is the simulated time of w by the real-time pacing
 * (pacing_sim_at; pacing NULL in --fast mode), and at most the simulated time of the previous
 * pump plus the wall time since then (a simulation behind the wall clock treats itself as
 * being at the wall clock at every pump, rather than queueing a client's bytes behind its
 * lag). Records the delays (to_bus_delay, to_client_late) in real time. Returns true if a
 * byte moved. */
bool pty_bridge_pump(pty_bridge_t *pty, const pacing_t *pacing);

/* The reader thread (for its name and scheduling policy). */
pthread_t pty_bridge_reader(const pty_bridge_t *pty);

/* The simulated time at which the next queued client chunk enters the wire (already
 * stamped by a pump), or SIM_CYCLES_NEVER. Run the world no further before pumping again. */
sim_cycles_t pty_bridge_next_input(const pty_bridge_t *pty);

/* When the adapter next hands bytes it holds to the host (its latency timer), or
 * SIM_CYCLES_NEVER. Run the world no further before pumping again, so they reach the client
 * at that simulated time. */
sim_cycles_t pty_bridge_next_output(const pty_bridge_t *pty);

/* While held, the client's bytes wait in the bridge (they enter the wire when it is let go, in
 * order, at that time). While hidden, the bytes on the bus are not shown to the client. A
 * second master holds the client until the bus is quiet, then hides its own exchange: the
 * client sees at most its next packet delayed. */
void pty_bridge_hold(pty_bridge_t *pty, bool held);
void pty_bridge_hide(pty_bridge_t *pty, bool hidden);

/* A descriptor that becomes readable when the client has written (for poll); drained by
 * pty_bridge_pump. */
int pty_bridge_wake_fd(const pty_bridge_t *pty);

#endif
