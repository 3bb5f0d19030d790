/* SPDX-License-Identifier: MIT */
#include "master_request.h"

#include "packet_encode.h"

static void run_until(const master_requester_t *r, sim_cycles_t t) { r->run_until(r->scheduler, t); }

master_reply_t master_exchange(const master_requester_t *requester, const uint8_t *bytes, size_t count, size_t expect,
                               uint8_t *reply, size_t reply_max) {
  master_t *m = requester->master;
  const master_wait_t *wait = &requester->wait;
  master_rx_clear(m);
  const sim_cycles_t sent_end = master_send(m, bytes, count);
  run_until(requester, sent_end);
  if (expect == 0) {
    run_until(requester, sent_end + wait->silence);
  } else {
    const sim_cycles_t limit = sent_end + wait->reply_timeout;
    while (*m->now < limit && master_rx_count(m) < expect) {
      run_until(requester, *m->now + wait->poll_step);
    }
    /* Straight to the end of the quiet time (one call when nothing more comes), again when a
     * byte came meanwhile. */
    const sim_cycles_t talk_end = limit + wait->talk_limit;
    while (wait->quiet_after) {
      const size_t n = master_rx_count(m);
      const sim_cycles_t quiet_end = (n ? master_rx(m, n - 1u)->end : sent_end) + wait->quiet_after;
      if (*m->now >= quiet_end || *m->now >= talk_end) {
        break;
      }
      run_until(requester, quiet_end < talk_end ? quiet_end : talk_end);
    }
  }
  const bus_rx_t *first = master_rx(m, 0);
  return (master_reply_t){.received = master_rx_values(m, reply, reply_max),
                          .request_end = sent_end,
                          .reply_start = first ? first->start : SIM_CYCLES_NEVER};
}

master_reply_t master_request(const master_requester_t *requester, uint8_t id, uint8_t instruction,
                              const uint8_t *params, size_t count, size_t expect, uint8_t *reply, size_t reply_max) {
  uint8_t packet[PACKET_MAX_PARAMS + PACKET_OVERHEAD];
  const size_t n = packet_encode(packet, id, instruction, params, count < PACKET_MAX_PARAMS ? count : PACKET_MAX_PARAMS);
  return master_exchange(requester, packet, n, expect, reply, reply_max);
}
