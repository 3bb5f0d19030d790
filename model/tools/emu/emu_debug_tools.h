/* SPDX-License-Identifier: GPL-3.0-or-later */
/* `serve --trace FILE.vcd [--trace-ids LIST]` and `serve --gdb ID[:PORT]` (docs/debugging.md):
 * the waveform file of the servos traced and the servo opened to avr-gdb, run beside the serve
 * loop.
 *
 * - The trace's events are committed after each run of the world and written to disk at most
 *   EMU_DEBUG_TRACE_FLUSH_US of wall time apart (and whenever gdb takes the world), so what is
 *   on disk lags at most that much wall time behind; closing it writes the rest.
 * - While gdb holds the world (world_held), only gdb is served, EMU_DEBUG_GDB_WAIT_US at a time,
 *   until it lets go or a stop is asked (emu_stop_signal.h): simulated time stands still, and
 *   real-time pacing starts again from there.
 * - The gdb port is closed before the shutdown's settling (a held servo runs on), the trace
 *   after it (its last events included). */
#ifndef EMU_DEBUG_TOOLS_H
#define EMU_DEBUG_TOOLS_H

#include <stdbool.h>
#include <stddef.h>

#include "emu_options.h"
#include "pacing.h"
#include "servo_gdb.h"
#include "world.h"
#include "world_trace.h"

#define EMU_DEBUG_TRACE_FLUSH_US 100000.0 /* the VCD on disk lags at most this much wall time */
#define EMU_DEBUG_GDB_WAIT_US 50000u      /* while gdb holds the bus: its requests are waited for */

typedef struct {
  world_trace_t *trace; /* NULL: no --trace, or closed */
  const char *trace_path;
  double trace_flush_at_us; /* wall clock */
  servo_gdb_t gdb;
  bool gdb_open;
} emu_debug_tools_t;

/* Opens the trace and the gdb port the options ask for (neither: nothing), with one line each
 * on stderr. False with err set; whatever was opened is then closed by emu_debug_close_gdb and
 * emu_debug_close_trace(d, world, false). */
bool emu_debug_open(emu_debug_tools_t *d, world_t *world, const serve_options_t *o, char *err, size_t err_len);

/* After each run of the world: the trace's final events, on disk every EMU_DEBUG_TRACE_FLUSH_US;
 * gdb's requests, without waiting. */
void emu_debug_after_run(emu_debug_tools_t *d);

/* While gdb holds the world: serves gdb alone until it lets go or a stop is asked, then resumes
 * pacing at the world's time. Returns at once when gdb does not hold it. */
void emu_debug_wait_while_held(emu_debug_tools_t *d, world_t *world, pacing_t *pacing);

/* Closes the gdb port, if open (a held servo runs on). */
void emu_debug_close_gdb(emu_debug_tools_t *d);

/* Writes the rest of the trace, if any, and closes it (one line on stderr when `report`).
 * False when the file could not be written whole (said on stderr). */
bool emu_debug_close_trace(emu_debug_tools_t *d, const world_t *world, bool report);

#endif
