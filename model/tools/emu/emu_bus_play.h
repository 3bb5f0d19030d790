/* SPDX-License-Identifier: GPL-3.0-or-later */
/* `serve --play-bus FILE.csv`: a scripted master on the bus, beside the pty. It sends the
 * client's rows of a --log-bus CSV (docs/emulator.md "The CSV": instructions, garbage and 2.0
 * frames alike, the `raw` bytes) each at its recorded `time_us` of simulated time, at the
 * bus's baud at start (a row due while the master is still sending starts after it), and
 * hears the answers without keeping them. The same file gives the same traffic at the same
 * simulated times in every run, --fast or --realtime: with --robot, the same joint
 * trajectories (docs/robot.md "Lock-step"). */
#ifndef EMU_BUS_PLAY_H
#define EMU_BUS_PLAY_H

#include <stddef.h>
#include <stdint.h>

#include "master.h"
#include "world.h"

typedef struct {
  sim_cycles_t at;
  uint8_t *bytes;
  size_t len;
} emu_play_row_t;

typedef struct {
  emu_play_row_t *rows;
  size_t count, next;
  master_t *master;
} emu_bus_play_t;

/* Reads the file's client rows. -1 with one line in err naming the file, the line and the
 * problem (no such file, a missing column, a time or raw bytes that do not parse, no client
 * row). */
int emu_bus_play_load(emu_bus_play_t *play, const char *path, char *err, size_t err_len);
/* Puts its master on the world's bus at bps, named "play" (its rows in --log-bus). -1 with err
 * set when the bus is full. */
int emu_bus_play_start(emu_bus_play_t *play, world_t *world, double bps, char *err, size_t err_len);
/* The next row's time, SIM_CYCLES_NEVER when all are sent: the world must not step past it
 * before emu_bus_play_poll. */
sim_cycles_t emu_bus_play_next(const emu_bus_play_t *play);
/* Sends every row due by now. */
void emu_bus_play_poll(emu_bus_play_t *play, sim_cycles_t now);
/* After the world is destroyed (its bus holds the master's node until then). */
void emu_bus_play_free(emu_bus_play_t *play);

#endif
