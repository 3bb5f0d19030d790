/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Real-time pacing: simulated time follows the wall clock (CLOCK_MONOTONIC).
 *
 * The serve loop runs the world in short slices; after each, pacing_wait() sleeps while the
 * simulation is ahead of the wall clock, waking early when the client writes (poll on the
 * pty). When the simulation falls behind (the host is too slow for the number of servos),
 * it runs flat out; a lag beyond PACING_MAX_LAG_US is dropped (the clocks are re-aligned) so
 * the emulator does not race to catch up. Ahead/behind figures are kept for reports. */
#ifndef SIM_PACING_H
#define SIM_PACING_H

#include <stdbool.h>
#include <stdint.h>

#include "sim_time.h"

#define PACING_MAX_LAG_US 200000.0

typedef struct {
  bool realtime;
  double wall0_us;         /* wall clock at the reference point */
  sim_cycles_t sim0;       /* simulated time at the reference point */
  double max_behind_us;    /* worst lag seen */
  double total_dropped_us; /* lag dropped by re-alignment */
  uint64_t realignments;
  double slept_us;
  double started_wall_us;
  sim_cycles_t started_sim;
} pacing_t;

double pacing_wall_us(void);

void pacing_start(pacing_t *pacing, bool realtime, sim_cycles_t sim_now);

/* After a pause in which simulated time stood still (a debugger held the world): the
 * reference moves to now, so the pause is neither lag nor caught up. */
void pacing_resume(pacing_t *pacing, sim_cycles_t sim_now);

/* Simulated minus wall time since the reference, in microseconds (positive: ahead). */
double pacing_ahead_us(const pacing_t *pacing, sim_cycles_t sim_now);

/* Realtime: waits until the wall clock reaches sim_now, or until fd (if >= 0) is readable.
 * Returns true when woken by fd. Fast mode: returns false at once. */
bool pacing_wait(pacing_t *pacing, sim_cycles_t sim_now, int fd);

/* The simulated time that corresponds to wall time wall_us (pacing_wall_us) by the current
 * reference (never before the reference's simulated time). */
sim_cycles_t pacing_sim_at(const pacing_t *pacing, double wall_us);

/* Simulated seconds per wall second since pacing_start. */
double pacing_speed(const pacing_t *pacing, sim_cycles_t sim_now);

#endif
