/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "rt_guard.h"

void rt_guard_start(rt_guard_t *g, double now_us) {
  *g = (rt_guard_t){.held = true,
                    .late_since_us = now_us,
                    .on_time_since_us = now_us,
                    .realigned_at_us = now_us - RT_GUARD_REALIGN_GRACE_US,
                    .last_block_us = now_us};
}

bool rt_guard_restart(rt_guard_t *g, double now_us) {
  g->yields = g->drops = 0;
  g->dropped_us = 0.0;
  g->dropped_at_us = now_us;
  g->late = false;
  g->on_time_since_us = now_us;
  g->last_block_us = now_us;
  if (g->held || g->given_up) {
    return false;
  }
  g->held = true;
  g->late_since_us = now_us;
  return true;
}

/* A late check starts a late spell; an on-time one ends it, but for a moment after a
 * re-alignment. */
static void track_lateness(rt_guard_t *g, double now_us, double ahead_us) {
  if (ahead_us < -RT_GUARD_LATE_US) {
    if (!g->late) {
      g->late = true;
      g->late_since_us = now_us;
    }
  } else if (g->late && now_us - g->realigned_at_us >= RT_GUARD_REALIGN_GRACE_US) {
    g->late = false;
    g->on_time_since_us = now_us;
  }
}

rt_guard_action_t rt_guard_check(rt_guard_t *g, double now_us, double ahead_us, bool will_block) {
  track_lateness(g, now_us, ahead_us);
  if (g->held) {
    if (g->late && now_us - g->late_since_us >= RT_GUARD_LATE_MAX_US) {
      g->held = false;
      g->drops++;
      g->dropped_at_us = now_us;
      return RT_GUARD_DROP;
    }
    if (!will_block && now_us - g->last_block_us >= RT_GUARD_RUN_MAX_US) {
      g->yields++;
      return RT_GUARD_YIELD;
    }
    return RT_GUARD_RUN;
  }
  const bool caught_up = !g->late && now_us - g->on_time_since_us >= RT_GUARD_ON_TIME_US;
  if (!g->given_up && (caught_up || now_us - g->dropped_at_us >= RT_GUARD_RETRY_US)) {
    g->held = true;
    g->dropped_us += now_us - g->dropped_at_us;
    g->late_since_us = now_us; /* on probation when still late: a whole late spell again */
    return RT_GUARD_RETAKE;
  }
  return RT_GUARD_RUN;
}

void rt_guard_realigned(rt_guard_t *g, double now_us) { g->realigned_at_us = now_us; }

void rt_guard_blocked(rt_guard_t *g, double now_us) { g->last_block_us = now_us; }

void rt_guard_give_up(rt_guard_t *g) {
  g->held = false;
  g->given_up = true;
}
