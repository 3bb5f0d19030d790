/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Real-time pacing: simulated time follows the wall clock (CLOCK_MONOTONIC).
 *
 * The serve loop runs the world in short slices; after each, pacing_wait() sleeps while the
 * simulation is ahead of the wall clock, waking early when the client writes (poll on the
 * pty). When the simulation falls behind (the host is too slow for the number of servos),
 * it runs flat out; a lag beyond PACING_MAX_LAG_US is dropped (the clocks are re-aligned) so
 * the emulator does not race to catch up. Ahead/behind figures are kept for reports.
 *
 * With a real-time policy (rt_policy.h, pacing_hold_rt) the pacing thread is never preempted by
 * an ordinary process, so it leaves its CPU or its policy by itself as rt_guard.h says: it
 * yields the CPU for a moment after a long run behind the clock, and drops the policy when it
 * stays late, taking it again once on time. */
#ifndef SIM_PACING_H
#define SIM_PACING_H

#include <stdbool.h>
#include <stdint.h>

#include "rt_guard.h"
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
  /* The calling thread's real-time policy (pacing_hold_rt): held or dropped, yields, drops. */
  bool rt_wanted;          /* it was taken */
  int rt_priority;
  rt_guard_t rt;
  bool stopped;            /* pacing_stop: the speed is that of the paced run */
  double stopped_wall_us;
  sim_cycles_t stopped_sim;
} pacing_t;

double pacing_wall_us(void);

void pacing_start(pacing_t *pacing, bool realtime, sim_cycles_t sim_now);

/* The calling thread holds a real-time policy at priority (rt_policy_take succeeded): from
 * now on pacing_wait yields, drops and takes it again as rt_guard.h says. */
void pacing_hold_rt(pacing_t *pacing, int priority);

/* The calling thread leaves its real-time policy for good (before running the world flat out
 * at shutdown). */
void pacing_release_rt(pacing_t *pacing);

/* After a pause in which simulated time stood still (a debugger held the world): the
 * reference moves to now, so the pause is neither lag nor caught up. */
void pacing_resume(pacing_t *pacing, sim_cycles_t sim_now);

/* As pacing_resume, and the figures (worst lag, re-alignments, speed, the real-time policy's
 * yields and drops) start again from now: those of the serving, not of the boot before it. */
void pacing_restart(pacing_t *pacing, sim_cycles_t sim_now);

/* The paced run ends at sim_now (what runs after it, the settling at shutdown, is not paced):
 * pacing_speed is that of the run up to here. */
void pacing_stop(pacing_t *pacing, sim_cycles_t sim_now);

/* Simulated minus wall time since the reference, in microseconds (positive: ahead). */
double pacing_ahead_us(const pacing_t *pacing, sim_cycles_t sim_now);

/* Realtime: waits until the wall clock reaches sim_now, or until fd (if >= 0) is readable.
 * Returns true when woken by fd. Fast mode: returns false at once. */
bool pacing_wait(pacing_t *pacing, sim_cycles_t sim_now, int fd);

/* The simulated time that corresponds to wall time wall_us (pacing_wall_us) by the current
 * reference (never before the reference's simulated time). */
sim_cycles_t pacing_sim_at(const pacing_t *pacing, double wall_us);

/* The wall time (pacing_wall_us) that corresponds to simulated time sim by the current
 * reference. */
double pacing_wall_at(const pacing_t *pacing, sim_cycles_t sim);

/* Simulated seconds per wall second since pacing_start (or pacing_restart), up to pacing_stop. */
double pacing_speed(const pacing_t *pacing, sim_cycles_t sim_now);

#endif
