/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include "pacing.h"

#include <poll.h>
#include <pthread.h>
#include <time.h>

#include "rt_policy.h"

double pacing_wall_us(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec * 1e6 + (double)ts.tv_nsec / 1e3;
}

void pacing_start(pacing_t *pacing, bool realtime, sim_cycles_t sim_now) {
  *pacing = (pacing_t){.realtime = realtime};
  pacing->wall0_us = pacing->started_wall_us = pacing_wall_us();
  pacing->sim0 = pacing->started_sim = sim_now;
}

void pacing_hold_rt(pacing_t *pacing, int priority) {
  pacing->rt_wanted = true;
  pacing->rt_priority = priority;
  rt_guard_start(&pacing->rt, pacing_wall_us());
}

/* The real-time policy taken again by this thread (rt_guard held it again); given up for good
 * when no longer allowed. */
static void retake_policy(pacing_t *pacing) {
  int priority = pacing->rt_priority;
  char why[240];
  if (rt_policy_take(pthread_self(), &priority, why, sizeof(why)) != 0) {
    rt_guard_give_up(&pacing->rt); /* no longer allowed: the ordinary policy from now on */
  }
}

void pacing_release_rt(pacing_t *pacing) {
  if (!pacing->rt_wanted) {
    return;
  }
  if (pacing->rt.held) {
    rt_policy_drop(pthread_self());
  } else if (!pacing->rt.given_up) {
    pacing->rt.dropped_us += pacing_wall_us() - pacing->rt.dropped_at_us;
  }
  rt_guard_give_up(&pacing->rt);
}

void pacing_resume(pacing_t *pacing, sim_cycles_t sim_now) {
  pacing->wall0_us = pacing_wall_us();
  pacing->sim0 = sim_now;
  rt_guard_blocked(&pacing->rt, pacing->wall0_us); /* the debugger's wait blocked */
}

void pacing_restart(pacing_t *pacing, sim_cycles_t sim_now) {
  pacing_resume(pacing, sim_now);
  pacing->started_wall_us = pacing->wall0_us;
  pacing->started_sim = sim_now;
  pacing->max_behind_us = pacing->total_dropped_us = pacing->slept_us = 0.0;
  pacing->realignments = 0;
  if (pacing->rt_wanted && rt_guard_restart(&pacing->rt, pacing->wall0_us)) {
    retake_policy(pacing); /* dropped while the boot ran late: the serving starts at it */
  }
}

void pacing_stop(pacing_t *pacing, sim_cycles_t sim_now) {
  pacing->stopped = true;
  pacing->stopped_wall_us = pacing_wall_us();
  pacing->stopped_sim = sim_now;
}

double pacing_ahead_us(const pacing_t *pacing, sim_cycles_t sim_now) {
  const double sim_us = sim_cycles_to_us(sim_now - pacing->sim0);
  return sim_us - (pacing_wall_us() - pacing->wall0_us);
}

static void sleep_us(double us) {
  const struct timespec ts = {.tv_sec = (time_t)(us / 1e6), .tv_nsec = (long)((us - (double)(time_t)(us / 1e6) * 1e6) * 1e3)};
  (void)clock_nanosleep(CLOCK_MONOTONIC, 0, &ts, NULL);
}

/* What rt_guard asks of a thread at the real-time policy, before it sleeps (will_block) or
 * runs on. */
static void guard_rt(pacing_t *pacing, double ahead_us, bool will_block) {
  if (!pacing->rt_wanted) {
    return;
  }
  switch (rt_guard_check(&pacing->rt, pacing_wall_us(), ahead_us, will_block)) {
    case RT_GUARD_YIELD:
      sleep_us(RT_GUARD_YIELD_US);
      rt_guard_blocked(&pacing->rt, pacing_wall_us());
      break;
    case RT_GUARD_DROP: rt_policy_drop(pthread_self()); break;
    case RT_GUARD_RETAKE: retake_policy(pacing); break;
    case RT_GUARD_RUN: break;
  }
}

bool pacing_wait(pacing_t *pacing, sim_cycles_t sim_now, int fd) {
  if (!pacing->realtime) {
    return false;
  }
  const double ahead = pacing_ahead_us(pacing, sim_now);
  if (ahead < 20.0) { /* behind, or too little ahead to be worth a system call */
    if (ahead < 0.0) {
      if (-ahead > pacing->max_behind_us) {
        pacing->max_behind_us = -ahead;
      }
      if (-ahead > PACING_MAX_LAG_US) {
        pacing->wall0_us += -ahead; /* drop the lag: align the wall reference to now */
        pacing->total_dropped_us += -ahead;
        pacing->realignments++;
        rt_guard_realigned(&pacing->rt, pacing_wall_us());
      }
    }
    guard_rt(pacing, ahead, false);
    return false;
  }
  guard_rt(pacing, ahead, true);
  struct timespec timeout = {.tv_sec = (time_t)(ahead / 1e6), .tv_nsec = (long)((ahead - (double)(time_t)(ahead / 1e6) * 1e6) * 1e3)};
  struct pollfd pfd = {.fd = fd, .events = POLLIN};
  const double before = pacing_wall_us();
  const int r = ppoll(fd >= 0 ? &pfd : NULL, fd >= 0 ? 1 : 0, &timeout, NULL);
  const double after = pacing_wall_us();
  pacing->slept_us += after - before;
  rt_guard_blocked(&pacing->rt, after);
  return r > 0 && (pfd.revents & POLLIN);
}

sim_cycles_t pacing_sim_at(const pacing_t *pacing, double wall_us) {
  const double since = wall_us - pacing->wall0_us;
  return pacing->sim0 + (since > 0.0 ? (sim_cycles_t)(since * SIM_CYCLES_PER_US) : 0u);
}

double pacing_wall_at(const pacing_t *pacing, sim_cycles_t sim) {
  const double since_us = sim >= pacing->sim0 ? sim_cycles_to_us(sim - pacing->sim0) : -sim_cycles_to_us(pacing->sim0 - sim);
  return pacing->wall0_us + since_us;
}

double pacing_speed(const pacing_t *pacing, sim_cycles_t sim_now) {
  if (pacing->stopped) {
    sim_now = pacing->stopped_sim;
  }
  const double wall = (pacing->stopped ? pacing->stopped_wall_us : pacing_wall_us()) - pacing->started_wall_us;
  return wall > 0.0 ? sim_cycles_to_us(sim_now - pacing->started_sim) / wall : 0.0;
}
