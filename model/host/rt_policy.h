/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A real-time scheduling policy for the emulator's threads that pace the simulation and carry
 * the client's bytes (docs/emulator.md "Real time on a busy machine"): SCHED_FIFO at a modest
 * priority, above every ordinary (SCHED_OTHER) process of the machine and below the kernel's
 * own real-time threads (threaded interrupts run at 50). SCHED_RESET_ON_FORK goes with it:
 * threads and processes the holder starts (the world's second thread, the dashboard) run at
 * the ordinary policy.
 *
 * Linux lets a thread take it as root, with CAP_SYS_NICE, or up to its RLIMIT_RTPRIO
 * (`ulimit -r`). Dropping it back to SCHED_OTHER is always allowed. A FIFO thread that never
 * blocks keeps its CPU from every ordinary task: pacing.h says how the pacing thread bounds
 * its runs. */
#ifndef SIM_RT_POLICY_H
#define SIM_RT_POLICY_H

#include <pthread.h>
#include <stddef.h>

/* The simulation's pacing thread; the pty's reader takes one more, so it preempts the
 * simulation when both share a CPU (its work per wake-up is a read and a queue entry,
 * microseconds). */
#define RT_POLICY_PACING_PRIORITY 10

/* Gives thread SCHED_FIFO at *priority (with SCHED_RESET_ON_FORK), or at the RLIMIT_RTPRIO
 * when that is lower and not 0 (*priority then says which). 0, or -1 with err set to why not,
 * in a user's words (what is missing and what would allow it). */
int rt_policy_take(pthread_t thread, int *priority, char *err, size_t err_len);

/* Back to SCHED_OTHER at nice 0 (its state before rt_policy_take). */
void rt_policy_drop(pthread_t thread);

#endif
