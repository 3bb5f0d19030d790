/* SPDX-License-Identifier: MIT */
/* Requests through a bus master (master.h), bounded by simulated time: send a request, run
 * the simulation until the reply has come (or a timeout), collect what came back with its
 * wire timing. The one requester of the tools (ax12-bench, ax12-lab) and the simulator tests
 * (test/sim/sim_harness.c). Pure C (MIT, as the rest of model/bus): the simulation is run
 * through a callback, world_requester() (model/simavr/world.h) binds it to a world. */
#ifndef MODEL_MASTER_REQUEST_H
#define MODEL_MASTER_REQUEST_H

#include <stddef.h>
#include <stdint.h>

#include "master.h"
#include "sim_time.h"

/* Advances the whole simulation (every node on the master's bus) to time t. */
typedef void (*master_run_until_fn)(void *scheduler, sim_cycles_t t);

/* How long a request waits, all in simulated cycles. */
typedef struct {
  sim_cycles_t poll_step;     /* the simulation runs this far between looks for the reply */
  sim_cycles_t reply_timeout; /* after the request's last stop bit: the expected bytes come by then or never */
  sim_cycles_t quiet_after;   /* then on until the line has been quiet this long after its last byte
                               * (bytes beyond the expected ones are collected too); 0: stop at once */
  sim_cycles_t talk_limit;    /* quiet_after ends at reply_timeout + talk_limit at the latest */
  sim_cycles_t silence;       /* a request expecting nothing watches the line this long */
} master_wait_t;

typedef struct {
  master_t *master;
  master_run_until_fn run_until;
  void *scheduler; /* run_until's first argument (a world_t) */
  master_wait_t wait;
} master_requester_t;

typedef struct {
  size_t received;          /* bytes that came back, as copied to the caller's reply buffer */
  sim_cycles_t request_end; /* end of the request's last stop bit */
  sim_cycles_t reply_start; /* start bit of the first byte heard back; SIM_CYCLES_NEVER: none */
} master_reply_t;

/* Forgets what the master heard, sends bytes, and runs the simulation: expect > 0 until that
 * many bytes came back (or reply_timeout), then per quiet_after; expect 0 for `silence`.
 * Copies what came back (at most reply_max bytes) to reply; the wire records stay in the
 * master (master_rx). */
master_reply_t master_exchange(const master_requester_t *requester, const uint8_t *bytes, size_t count, size_t expect,
                               uint8_t *reply, size_t reply_max);

/* master_exchange of the instruction packet (packet_encode.h) id, instruction, params. */
master_reply_t master_request(const master_requester_t *requester, uint8_t id, uint8_t instruction,
                              const uint8_t *params, size_t count, size_t expect, uint8_t *reply, size_t reply_max);

#endif
