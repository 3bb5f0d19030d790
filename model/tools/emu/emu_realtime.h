/* SPDX-License-Identifier: GPL-3.0-or-later */
/* `serve` in real time on a busy machine (docs/emulator.md "Real time on a busy machine"): the
 * real-time scheduling policy (rt_policy.h) for the thread that paces the world (the caller)
 * and for the pty's reader, where the system allows it, never in --fast; otherwise one line on
 * stderr, once, saying what could not be had and what that means. */
#ifndef EMU_REALTIME_H
#define EMU_REALTIME_H

#include <stdbool.h>
#include <stddef.h>

#include "pacing.h"
#include "pty_bridge.h"

typedef struct {
  bool asked;            /* real time (not --fast) */
  bool held;             /* the pacing thread and the reader got SCHED_FIFO */
  int pacing_priority;
  int reader_priority;
  char why_not[240];     /* asked and not held: why */
  /* Start-up (emu_serve): the boot until every servo listens, in simulated and wall time, and
   * the wall time of the warm-up after it, until `ready:`. */
  double boot_sim_us;
  double boot_wall_us;
  double warm_wall_us;
} emu_realtime_t;

/* Takes the policy for the calling thread (registered with pacing, pacing_hold_rt) and for the
 * pty's reader when realtime; prints the one line when it cannot. */
void emu_realtime_take(emu_realtime_t *rt, bool realtime, pacing_t *pacing, const pty_bridge_t *pty);

/* The policy taken, in a few words: "SCHED_FIFO 10 (pty reader 11)", "ordinary scheduling:
 * <why>", "ordinary scheduling (--fast)" (pacing_t says when the pacing thread dropped it). */
void emu_realtime_describe(const emu_realtime_t *rt, char *out, size_t out_len);

#endif
