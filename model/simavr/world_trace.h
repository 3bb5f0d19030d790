/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A waveform trace of a world's servos in one VCD file on one timebase (the world's cycle
 * counter): one scope per servo (`servo_<id>`, from the servo's name) with the signals of
 * servo_trace.h. The probes collect events per servo; world_trace_commit() writes, in time
 * order, every event that no later delivery can precede: those before the world's time and
 * before the first byte still on the wire (bus_first_pending_start), whose bits the
 * receivers' rx signals get only when the bus finalizes it.
 *
 * Costs nothing for a world without one: the probes exist only on traced servos. */
#ifndef SIM_WORLD_TRACE_H
#define SIM_WORLD_TRACE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "servo_trace.h"
#include "vcd_writer.h"
#include "world.h"

typedef struct {
  servo_trace_event_t event;
  uint32_t servo; /* index in world_trace_t.traces */
} world_trace_entry_t;

typedef struct {
  world_t *world;
  vcd_writer_t vcd;
  servo_trace_t *traces;
  int *var_base; /* the VCD variable of each trace's signal 0 */
  size_t count;
  world_trace_entry_t *scratch;
  size_t scratch_cap;
  sim_cycles_t committed; /* everything before this is written */
  uint64_t changes;       /* events handed to the writer */
} world_trace_t;

/* Creates path and probes the world's servos for which traced[i] is true (every servo when
 * traced is NULL), from now on. Call before the world runs (the trace starts at its time).
 * NULL with err set on failure. */
world_trace_t *world_trace_open(world_t *world, const char *path, const bool *traced, char *err, size_t err_len);

/* Writes what can be written now (see above); call between world steps, as often as wanted. */
void world_trace_commit(world_trace_t *wt);

/* Commits, then writes out the file's buffer (world_trace_commit alone leaves up to 64 KB in
 * memory). Returns 0, or -1 when a write failed. */
int world_trace_flush(world_trace_t *wt);

/* Writes every event left, ends the file at the world's time, closes it and detaches the
 * probes (before the world is destroyed). Returns 0, or -1 when a write failed. */
int world_trace_close(world_trace_t *wt);

#endif
