/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include "pacing.h"

#include <poll.h>
#include <time.h>

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

void pacing_resume(pacing_t *pacing, sim_cycles_t sim_now) {
  pacing->wall0_us = pacing_wall_us();
  pacing->sim0 = sim_now;
}

double pacing_ahead_us(const pacing_t *pacing, sim_cycles_t sim_now) {
  const double sim_us = sim_cycles_to_us(sim_now - pacing->sim0);
  return sim_us - (pacing_wall_us() - pacing->wall0_us);
}

bool pacing_wait(pacing_t *pacing, sim_cycles_t sim_now, int fd) {
  if (!pacing->realtime) {
    return false;
  }
  const double ahead = pacing_ahead_us(pacing, sim_now);
  if (ahead < 0.0) {
    if (-ahead > pacing->max_behind_us) {
      pacing->max_behind_us = -ahead;
    }
    if (-ahead > PACING_MAX_LAG_US) {
      pacing->wall0_us += -ahead; /* drop the lag: align the wall reference to now */
      pacing->total_dropped_us += -ahead;
      pacing->realignments++;
    }
    return false;
  }
  if (ahead < 20.0) {
    return false; /* not worth a system call */
  }
  struct timespec timeout = {.tv_sec = (time_t)(ahead / 1e6), .tv_nsec = (long)((ahead - (double)(time_t)(ahead / 1e6) * 1e6) * 1e3)};
  struct pollfd pfd = {.fd = fd, .events = POLLIN};
  const double before = pacing_wall_us();
  const int r = ppoll(fd >= 0 ? &pfd : NULL, fd >= 0 ? 1 : 0, &timeout, NULL);
  pacing->slept_us += pacing_wall_us() - before;
  return r > 0 && (pfd.revents & POLLIN);
}

sim_cycles_t pacing_sim_at(const pacing_t *pacing, double wall_us) {
  const double since = wall_us - pacing->wall0_us;
  return pacing->sim0 + (since > 0.0 ? (sim_cycles_t)(since * SIM_CYCLES_PER_US) : 0u);
}

double pacing_speed(const pacing_t *pacing, sim_cycles_t sim_now) {
  const double wall = pacing_wall_us() - pacing->started_wall_us;
  return wall > 0.0 ? sim_cycles_to_us(sim_now - pacing->started_sim) / wall : 0.0;
}
