/* SPDX-License-Identifier: GPL-3.0-or-later */
#include <stdio.h>
#include <stdlib.h>

#include "bench_commands.h"
#include "bench_rig.h"
#include "bench_workload.h"
#include "dxl_protocol.h"
#include "dxl_table.h"

/* Load: back-to-back SYNC_WRITEs (bytes lost), and the simulation's speed idle and under the
 * client loop. */

/* Every servo answers a PING (after a quiet spell past the 100 ms gap rule); returns how many
 * do not. */
static unsigned servos_silent(bench_rig_t *r, unsigned servos) {
  world_run_until(r->world, r->world->now + MS(120));
  unsigned silent = 0;
  for (unsigned id = 1; id <= servos; id++) {
    uint8_t q[8], reply[8];
    bench_exchange(r, q, packet_encode(q, (uint8_t)id, DXL_INST_PING, NULL, 0), 6);
    silent += master_rx_values(r->master, reply, sizeof reply) != 6;
  }
  return silent;
}

void bench_sustained(unsigned servos, double seconds, bool garbage) {
  bench_rig_t r;
  bench_rig_open(&r, servos);
  long dropped_before = 0, ticks_before = 0, control_before = 0;
  for (size_t i = 0; i < r.world->servo_count; i++) {
    dropped_before += bench_firmware_counter(r.world->servos[i], "uart_rx_dropped_count", 1);
    ticks_before += bench_firmware_counter(r.world->servos[i], "timebase_ms_count", 2);
    control_before += bench_firmware_counter(r.world->servos[i], "control_tick_count", 2);
  }
  uint64_t overruns_before = 0;
  for (size_t i = 0; i < r.world->servo_count; i++) overruns_before += r.world->servos[i]->board.link.rx_overruns;
  const sim_cycles_t t0 = r.world->now, until = t0 + (sim_cycles_t)(seconds * 1e6 * SIM_CYCLES_PER_US);
  size_t bytes = 0;
  const unsigned packets = bench_back_to_back(&r, servos, until, garbage, &bytes);
  world_run_until(r.world, r.master->tx_end);
  const double elapsed_ms = (double)(r.world->now - t0) / SIM_CYCLES_PER_US / 1000.0;
  long dropped = -dropped_before, ticks = -ticks_before, control = -control_before;
  uint64_t overruns = 0;
  for (size_t i = 0; i < r.world->servo_count; i++) {
    dropped += bench_firmware_counter(r.world->servos[i], "uart_rx_dropped_count", 1);
    ticks += bench_firmware_counter(r.world->servos[i], "timebase_ms_count", 2);
    control += bench_firmware_counter(r.world->servos[i], "control_tick_count", 2);
    overruns += r.world->servos[i]->board.link.rx_overruns;
  }
  overruns -= overruns_before;
  /* Check the last SYNC_WRITE landed: read every goal back after the load (after garbage:
   * every servo answers again). */
  unsigned wrong_goals = 0;
  world_run_until(r.world, r.world->now + MS(5));
  const unsigned phase = (packets - 1) / 200;
  for (unsigned id = 1; id <= servos && !garbage; id++) {
    uint8_t q[8], params[2] = {CT_ADDR_GOAL_POSITION, 2}, reply[8];
    bench_exchange(&r, q, packet_encode(q, (uint8_t)id, DXL_INST_READ, params, 2), 8);
    const size_t got = master_rx_values(r.master, reply, sizeof reply);
    const unsigned goal = (phase & 1) ? 300 + id * 10 : 700 - id * 10;
    wrong_goals += !(got == 8 && (unsigned)(reply[5] | reply[6] << 8) == goal);
  }
  const long expected_ticks = (long)elapsed_ms * (long)servos; /* whole milliseconds: each servo may count one more */
  const unsigned silent_after = garbage ? servos_silent(&r, servos) : 0;
  printf("{\"garbage\": %s, \"servos_silent_after\": %u, \"servos\": %u, \"simulated_s\": %.3f, \"packets\": %u, \"bytes\": %zu, \"wire_busy_fraction\": %.4f, "
         "\"bytes_lost_uart_overrun\": %llu, \"bytes_dropped_by_firmware\": %ld, \"goals_wrong_after_load\": %u, "
         "\"timer_ticks\": %ld, \"timer_ticks_expected\": %ld, \"control_ticks_run\": %ld}\n",
         garbage ? "true" : "false", silent_after, servos, elapsed_ms / 1000.0, packets, bytes, (double)bytes * 10.0 / (elapsed_ms * 1000.0),
         (unsigned long long)overruns, dropped < 0 ? -1 : dropped, wrong_goals, ticks, expected_ticks,
         control_before < 0 ? -1 : control);
  bench_rig_close(&r);
}

void bench_speed(unsigned servos, double seconds) {
  bench_rig_t r;
  bench_rig_open(&r, servos);
  const sim_cycles_t span = (sim_cycles_t)(seconds * 1e6 * SIM_CYCLES_PER_US);
  double w0 = bench_wall_s();
  world_run_until(r.world, r.world->now + span);
  const double idle_speed = seconds / (bench_wall_s() - w0);
  bench_torque_on_all(&r, servos);
  w0 = bench_wall_s();
  const sim_cycles_t t0 = r.world->now;
  const unsigned loops = bench_client_loops(&r, servos, t0 + span);
  const double loaded_wall = bench_wall_s() - w0;
  const double loaded_sim = (double)(r.world->now - t0) / SIM_CYCLES_PER_US / 1e6;
  printf("{\"servos\": %u, \"idle_sim_s_per_wall_s\": %.3f, \"loaded_sim_s_per_wall_s\": %.3f, "
         "\"client_loops_per_sim_s\": %.1f, \"loaded_sim_s\": %.6f}\n",
         servos, idle_speed, loaded_sim / loaded_wall, loops / loaded_sim, loaded_sim);
  bench_rig_close(&r);
}

