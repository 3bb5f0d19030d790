/* SPDX-License-Identifier: GPL-3.0-or-later */
/* When the pacing thread, at a real-time policy (rt_policy.h), must leave its CPU or the
 * policy: pure, on the times it is given (microseconds of CLOCK_MONOTONIC), no system calls.
 *
 * A SCHED_FIFO thread is never preempted by an ordinary process, so one that runs behind the
 * clock and never sleeps would keep its CPU from every ordinary task on it (the client, which
 * may busy-poll, and the kernel's pty worker) but for the kernel's 5 % reserve. Rules:
 * - Yield: after RT_GUARD_RUN_MAX_US of running without blocking, block RT_GUARD_YIELD_US:
 *   every ordinary task on that CPU runs at least that often and waits at most that long.
 * - Drop: late by more than RT_GUARD_LATE_US at every check for RT_GUARD_LATE_MAX_US on end (the
 *   host cannot run this world in real time even at priority; a world that catches up now and
 *   then, however briefly, is not hopeless): back to the ordinary policy, where the kernel
 *   shares the CPU fairly.
 * - Take again: once on time (late by RT_GUARD_LATE_US at most) at every check for
 *   RT_GUARD_ON_TIME_US on end, or on probation RT_GUARD_RETRY_US after the drop (the load
 *   that made it late may be gone; if not, the drop rule applies again): a hopeless world holds
 *   the policy at most RT_GUARD_LATE_MAX_US of every RT_GUARD_RETRY_US + RT_GUARD_LATE_MAX_US.
 * A re-alignment of the clocks (pacing.h drops a lag of 200 ms) leaves the simulation on time
 * for a moment without having caught up: for RT_GUARD_REALIGN_GRACE_US after one, being on
 * time ends no late spell. */
#ifndef SIM_RT_GUARD_H
#define SIM_RT_GUARD_H

#include <stdbool.h>
#include <stdint.h>

#define RT_GUARD_RUN_MAX_US 5000.0
#define RT_GUARD_YIELD_US 500.0
#define RT_GUARD_LATE_US 1000.0
#define RT_GUARD_LATE_MAX_US 1e6
#define RT_GUARD_ON_TIME_US 100000.0
#define RT_GUARD_RETRY_US 10e6
#define RT_GUARD_REALIGN_GRACE_US 100000.0

typedef enum {
  RT_GUARD_RUN,    /* go on */
  RT_GUARD_YIELD,  /* block RT_GUARD_YIELD_US, then rt_guard_blocked */
  RT_GUARD_DROP,   /* leave the real-time policy */
  RT_GUARD_RETAKE, /* take it again */
} rt_guard_action_t;

typedef struct {
  bool held;              /* the thread holds the policy now */
  bool given_up;          /* taking it again failed: never again */
  bool late;              /* in a late spell: from a late check to the next on-time one */
  double late_since_us;   /* the first late check of this late spell */
  double on_time_since_us;/* the first on-time check after the last late spell */
  double realigned_at_us; /* the last re-alignment of the clocks */
  double last_block_us;   /* the thread last blocked (slept or yielded) */
  double dropped_at_us;
  uint64_t yields;
  uint64_t drops;
  double dropped_us;      /* wall time without the policy after drops */
} rt_guard_t;

/* The thread holds the policy from now_us. */
void rt_guard_start(rt_guard_t *g, double now_us);

/* From now_us the counts start again and the lateness so far is forgotten (a boot slower than
 * real time is no late spell of the serving after it). A policy dropped during that boot (and
 * not given up) counts as held again from now_us, on probation: returns true, and the caller
 * takes it again. */
bool rt_guard_restart(rt_guard_t *g, double now_us);

/* At each pacing check: the simulation is ahead_us ahead of the clock (negative: late), and
 * will_block tells whether the thread is about to sleep. Returns what to do first. */
rt_guard_action_t rt_guard_check(rt_guard_t *g, double now_us, double ahead_us, bool will_block);

/* The clocks were re-aligned at now_us (a lag dropped). */
void rt_guard_realigned(rt_guard_t *g, double now_us);

/* The thread blocked (slept or yielded) until now_us. */
void rt_guard_blocked(rt_guard_t *g, double now_us);

/* Taking the policy again failed: the thread stays at the ordinary policy for good. */
void rt_guard_give_up(rt_guard_t *g);

#endif
