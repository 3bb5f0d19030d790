/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The serve loop of `ax12-emu serve`: the world of servos on their plants, the pty bridge,
 * real-time pacing, the waveform trace and the gdb port (docs/debugging.md), and a clean stop
 * with every EEPROM persisted and the trace complete. */
#ifndef EMU_SERVE_H
#define EMU_SERVE_H

#include "emu_options.h"

/* Runs until SIGINT, SIGTERM or SIGHUP. Prints `ready: <device>` on stdout once every servo
 * listens (at most 2 s of simulated boot) and 10 ms of simulated time more ran on time (in
 * real time: the first request is served in real time), everything else on stderr. Returns
 * the exit status: 0 after a clean stop, 1 when a servo, the pty or persisting failed. */
int emu_serve(const serve_options_t *o);

#endif
