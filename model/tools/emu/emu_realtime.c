/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include "emu_realtime.h"

#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <sys/prctl.h>

#include "rt_policy.h"

void emu_realtime_take(emu_realtime_t *rt, bool realtime, pacing_t *pacing, const pty_bridge_t *pty) {
  memset(rt, 0, sizeof(*rt));
  rt->asked = realtime;
  if (!realtime) {
    return;
  }
  /* Pacing sleeps wake when asked, not up to 50 us later (the default timer slack of an
   * ordinary thread; a real-time one has none). */
  (void)prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  rt->pacing_priority = RT_POLICY_PACING_PRIORITY;
  if (rt_policy_take(pthread_self(), &rt->pacing_priority, rt->why_not, sizeof(rt->why_not)) != 0) {
    fprintf(stderr,
            "ax12-emu: note: running at the ordinary scheduling policy: %s. On a busy machine the client's bytes "
            "and the replies may then wait for a CPU and a reply come late (docs/emulator.md \"Real time on a busy "
            "machine\"); `setcap cap_sys_nice+ep` on ax12-emu or an rtprio limit allows it\n",
            rt->why_not);
    return;
  }
  rt->reader_priority = rt->pacing_priority + 1; /* RLIMIT_RTPRIO may make it the same */
  char reader_err[sizeof(rt->why_not)];
  if (rt_policy_take(pty_bridge_reader(pty), &rt->reader_priority, reader_err, sizeof(reader_err)) != 0) {
    rt->reader_priority = 0; /* cannot be when the first was allowed: the reader stays ordinary */
  }
  rt->held = true;
  pacing_hold_rt(pacing, rt->pacing_priority);
}

void emu_realtime_describe(const emu_realtime_t *rt, char *out, size_t out_len) {
  if (!rt->asked) {
    snprintf(out, out_len, "ordinary scheduling (--fast)");
  } else if (!rt->held) {
    snprintf(out, out_len, "ordinary scheduling: %s", rt->why_not);
  } else {
    snprintf(out, out_len, "SCHED_FIFO %d (pty reader %d)", rt->pacing_priority, rt->reader_priority);
  }
}
