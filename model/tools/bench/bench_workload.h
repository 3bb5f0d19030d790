/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The traffic of ax12-bench's measurements: SYNC_WRITEs of goals to every servo, torque on
 * everywhere, and the client loop of the issue (a SYNC_WRITE of goals, then a READ of every
 * servo), as scripts/bench.py's DynamixelSDK loop sends it. */
#ifndef BENCH_WORKLOAD_H
#define BENCH_WORKLOAD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "bench_rig.h"

/* A SYNC_WRITE to servos 1..servos from address 30: Goal Position only (2 bytes each, the
 * issue's client loop, LENGTH 94 for 30 servos), or Goal Position and Moving Speed 0 (4 bytes
 * each, 158 bytes for 30: the longest packet of the sustained load). The goals alternate
 * with phase's parity. Returns the packet's size. */
size_t bench_sync_write_goals(uint8_t *out, unsigned servos, unsigned phase, bool with_speed);

/* Torque on in servos 1..servos (one SYNC_WRITE), as the SDK loop (scripts/bench.py) does. */
void bench_torque_on_all(bench_rig_t *r, unsigned servos);

/* The client loop of the issue until simulated time `until`: one SYNC_WRITE of goal
 * positions, then a READ of Present Position from every servo, waiting for each reply.
 * Returns the loops completed. */
unsigned bench_client_loops(bench_rig_t *r, unsigned servos, sim_cycles_t until);

/* Back-to-back SYNC_WRITEs of goals and speeds to servos 1..servos until simulated time
 * `until`, the wire never idle; with garbage each has a bad checksum (a byte more than its
 * LENGTH says before it), so every servo rejects and rescans it. Returns the packets sent;
 * *bytes (if not NULL) counts their bytes. */
unsigned bench_back_to_back(bench_rig_t *r, unsigned servos, sim_cycles_t until, bool garbage, size_t *bytes);

#endif
