/* SPDX-License-Identifier: GPL-3.0-or-later */
/* `serve --stats`: the run's figures on stderr at exit ("ax12-emu: ..."): a line with the
 * simulated time and its speed against real time (in real time also the worst lag and the
 * re-alignments), the client's bytes both ways, bus collisions and baud mismatches; a line of
 * the USB adapter's packets, latency waits and frame waits, and the baud the bus saw; a line of
 * timing: the scheduling policy, the delay of the client's bytes to the bus and (in real time)
 * how late the adapter's hand-overs reached the pty, p50 / p99 / max, the worst lag, and how
 * often the pacing thread yielded its CPU or dropped its policy behind real time; a line of
 * the noise's corrupted bytes and flipped bits when there is noise; and a line per servo: its
 * UART counts, EEPROM writes and persists, flash page operations, watchdog resets, and whether
 * it halted. */
#ifndef EMU_STATS_H
#define EMU_STATS_H

#include "emu_realtime.h"
#include "pacing.h"
#include "pty_bridge.h"
#include "world.h"

void emu_stats_print(const world_t *world, const pty_bridge_t *pty, const pacing_t *pacing,
                     const emu_realtime_t *rt);

#endif
