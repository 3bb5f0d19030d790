/* SPDX-License-Identifier: GPL-3.0-or-later */
/* ax12-bench's commands (bench_main.c dispatches): each prints one JSON object on stdout. */
#ifndef BENCH_COMMANDS_H
#define BENCH_COMMANDS_H

#include <stdbool.h>

void bench_turnaround(unsigned requests);             /* bench_reply_timing.c */
void bench_rdt(void);                                 /* bench_reply_timing.c */
void bench_sustained(unsigned servos, double seconds, bool garbage); /* bench_load.c */
void bench_speed(unsigned servos, double seconds);    /* bench_load.c */
void bench_awake(void);                               /* bench_cycles.c */
typedef enum { BENCH_LOAD_CLIENT_LOOP, BENCH_LOAD_SYNC_WRITES, BENCH_LOAD_GARBAGE } bench_load_t;
void bench_profile(unsigned servos, double seconds, bench_load_t load); /* bench_cycles.c */
void bench_stack(void);                               /* bench_stack.c */
void bench_robot(const char *robot, double seconds);  /* bench_robot.c */

#endif
