/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The world's servos on one thread or two (world_set_threads, world_park in world.h): within
 * a step the servos do not interact, so a second thread can run half of them. It is handed a
 * step through a generation counter and reports it done through another; each side spins
 * briefly (a step takes microseconds), then sleeps on a futex. */
#ifndef SIM_WORLD_THREADS_H
#define SIM_WORLD_THREADS_H

#include "sim_time.h"
#include "world.h"

/* Every servo to `horizon`: the first half on the caller's thread, the second half on the
 * second thread when there is one. Returns when all have reached it. */
void world_run_servos(world_t *world, sim_cycles_t horizon);

/* At the first world_run_until() without a world_set_threads() before: the number of threads
 * from AX12_SIM_THREADS in the environment (default 1). */
void world_choose_threads(world_t *world);

#endif
