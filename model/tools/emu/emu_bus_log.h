/* SPDX-License-Identifier: GPL-3.0-or-later */
/* `serve --log-bus FILE.csv`: the bus monitor (model/bus/bus_monitor.h) installed on the bus,
 * the pty's node as its client, and the CSV file (model/host/bus_log.h) as its listener.
 * Without the option nothing is installed: the bus has no tap and the calls below do nothing. */
#ifndef EMU_BUS_LOG_H
#define EMU_BUS_LOG_H

#include <stdbool.h>
#include <stddef.h>

#include "bus.h"
#include "bus_log.h"
#include "bus_monitor.h"

typedef struct {
  bus_monitor_t *monitor; /* NULL: no log */
  bus_log_t log;
} emu_bus_log_t;

/* path NULL: no log (0). Else creates the file and installs the monitor on bus with
 * client_node as the client; -1 with err set when the file cannot be created. */
int emu_bus_log_start(emu_bus_log_t *bl, const char *path, bus_t *bus, int client_node, char *err, size_t err_len);

/* Every slice of the serve loop: partial packets past the gap at `now` reported, rows
 * flushed when their period has passed on the wall clock (pacing_wall_us, read only when a
 * log is kept). */
void emu_bus_log_tick(emu_bus_log_t *bl, sim_cycles_t now);

/* At exit, after the last simulation step: partial packets reported (as garbage), the counts
 * on stderr with `stats`, the monitor removed, the file closed. -1 (message on stderr) when
 * rows were lost to a failed write. */
int emu_bus_log_stop(emu_bus_log_t *bl, bool stats);

#endif
