/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include "rt_policy.h"

#include <errno.h>
#include <sched.h>
#include <stdio.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

static int set_fifo(pthread_t thread, int priority) {
  const struct sched_param param = {.sched_priority = priority};
  return pthread_setschedparam(thread, SCHED_FIFO | SCHED_RESET_ON_FORK, &param);
}

int rt_policy_take(pthread_t thread, int *priority, char *err, size_t err_len) {
  const int rc = set_fifo(thread, *priority);
  struct rlimit limit;
  const long rtprio = getrlimit(RLIMIT_RTPRIO, &limit) == 0 ? (long)limit.rlim_cur : 0L;
  if (rc == EPERM && rtprio > 0 && rtprio < *priority && set_fifo(thread, (int)rtprio) == 0) {
    *priority = (int)rtprio; /* what RLIMIT_RTPRIO allows */
    return 0;
  }
  if (rc == 0) {
    return 0;
  }
  const int priority_asked = *priority;
  if (rc != EPERM) {
    snprintf(err, err_len, "SCHED_FIFO %d: %s", priority_asked, strerror(rc));
    return -1;
  }
  snprintf(err, err_len,
           "SCHED_FIFO %d needs CAP_SYS_NICE or an RLIMIT_RTPRIO of at least %d, and this process has neither "
           "(ulimit -r is %ld%s)",
           priority_asked, priority_asked, rtprio,
           geteuid() == 0 ? "; it runs as root without the capability, as in a container" : "");
  return -1;
}

void rt_policy_drop(pthread_t thread) {
  const struct sched_param param = {.sched_priority = 0};
  (void)pthread_setschedparam(thread, SCHED_OTHER | SCHED_RESET_ON_FORK, &param);
}
