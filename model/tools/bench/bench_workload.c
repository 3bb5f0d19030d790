/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "bench_workload.h"

#include "dxl_protocol.h"
#include "dxl_table.h"
#include "packet_encode.h"

size_t bench_sync_write_goals(uint8_t *out, unsigned servos, unsigned phase, bool with_speed) {
  uint8_t params[2 + 5 * 32];
  size_t n = 0;
  params[n++] = CT_ADDR_GOAL_POSITION; /* Goal Position, Moving Speed */
  params[n++] = with_speed ? 4 : 2;
  for (unsigned id = 1; id <= servos; id++) {
    const unsigned goal = (phase & 1) ? 300 + id * 10 : 700 - id * 10;
    params[n++] = (uint8_t)id;
    params[n++] = (uint8_t)(goal & 0xFF);
    params[n++] = (uint8_t)(goal >> 8);
    if (with_speed) {
      params[n++] = 0;
      params[n++] = 0;
    }
  }
  return packet_encode(out, DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE, params, n);
}

void bench_torque_on_all(bench_rig_t *r, unsigned servos) {
  uint8_t torque_on[2 + 2 * 32];
  size_t n = 0;
  torque_on[n++] = CT_ADDR_TORQUE_ENABLE;
  torque_on[n++] = 1;
  for (unsigned id = 1; id <= servos; id++) {
    torque_on[n++] = (uint8_t)id;
    torque_on[n++] = 1;
  }
  uint8_t p[80];
  master_send(r->master, p, packet_encode(p, DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE, torque_on, n));
}

unsigned bench_back_to_back(bench_rig_t *r, unsigned servos, sim_cycles_t until, bool garbage, size_t *bytes) {
  uint8_t p[200];
  unsigned packets = 0;
  while (r->world->now < until) {
    if (r->master->tx_end <= r->world->now + US(200)) { /* keep the wire busy: no gap */
      size_t n = bench_sync_write_goals(p, servos, packets / 200, true);
      if (garbage) {
        p[n] = p[n - 1u];
        p[n - 1u] = 0x55;
        n++;
      }
      master_send(r->master, p, n);
      packets++;
      if (bytes != NULL) {
        *bytes += n;
      }
    }
    world_run_until(r->world, r->world->now + US(50));
  }
  return packets;
}

unsigned bench_client_loops(bench_rig_t *r, unsigned servos, sim_cycles_t until) {
  unsigned loops = 0;
  uint8_t p[200];
  while (r->world->now < until) {
    const size_t n = bench_sync_write_goals(p, servos, loops / 50, false);
    master_send(r->master, p, n);
    for (unsigned id = 1; id <= servos; id++) {
      uint8_t q[8], params[2] = {CT_ADDR_PRESENT_POSITION, 2};
      bench_exchange(r, q, packet_encode(q, (uint8_t)id, DXL_INST_READ, params, 2), 8);
    }
    loops++;
  }
  return loops;
}

