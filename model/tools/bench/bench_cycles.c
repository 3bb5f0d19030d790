/* SPDX-License-Identifier: GPL-3.0-or-later */
#include <stdio.h>
#include <stdlib.h>
#include <stdbool.h>

#include <sim_avr.h>

#include "bench_commands.h"
#include "bench_rig.h"
#include "bench_workload.h"
#include "dxl_table.h"

/* Where the firmware's cycles go: the awake share and the cycle profile by instruction. */

/* Prints `"name": {"0xADDR": cycles, ...}` (byte addresses) and clears the counts. */
static void print_cycle_profile(const char *name, uint64_t *word_cycles, size_t words) {
  printf("\"%s\": {", name);
  const char *sep = "";
  for (size_t w = 0; w < words; w++) {
    if (word_cycles[w]) {
      printf("%s\"0x%04zx\": %llu", sep, w * 2u, (unsigned long long)word_cycles[w]);
      sep = ", ";
      word_cycles[w] = 0;
    }
  }
  printf("}");
}

/* Cycles every servo has been awake so far, summed: its clock less its time asleep. */
static uint64_t awake_cycles_of_all(const bench_rig_t *r) {
  uint64_t awake = 0;
  for (size_t i = 0; i < r->world->servo_count; i++) {
    const servo_t *s = r->world->servos[i];
    awake += s->avr->cycle - s->sleep_cycles;
  }
  return awake;
}

/* Awake cycles by instruction, summed over the servos (scripts/firmware_profile names them):
 * `seconds` holding a position with torque on and no traffic, then `seconds` of the load: the
 * client loop of `speed`, or back-to-back SYNC_WRITEs (with garbage: each a bad checksum).
 * "loops" counts client loops or packets. One JSON object. */
void bench_profile(unsigned servos, double seconds, bench_load_t load) {
  bench_rig_t r;
  bench_rig_open(&r, servos);
  (void)world_set_threads(r.world, 1); /* the servos share one array */
  const sim_cycles_t span = (sim_cycles_t)(seconds * 1e6 * SIM_CYCLES_PER_US);
  bench_torque_on_all(&r, servos);
  world_run_until(r.world, r.world->now + MS(100));
  const size_t words = (r.world->servos[0]->avr->flashend + 1u) / 2u;
  uint64_t *word_cycles = calloc(words, sizeof *word_cycles);
  if (!word_cycles) bench_die("out of memory", NULL);
  for (size_t i = 0; i < r.world->servo_count; i++) {
    r.world->servos[i]->pc_cycles = word_cycles;
    r.world->servos[i]->pc_cycles_words = words;
  }
  printf("{\"servos\": %u, \"seconds\": %.3f, ", servos, seconds);
  uint64_t awake = awake_cycles_of_all(&r);
  world_run_until(r.world, r.world->now + span);
  printf("\"holding_awake_cycles\": %llu, ", (unsigned long long)(awake_cycles_of_all(&r) - awake));
  print_cycle_profile("holding", word_cycles, words);
  awake = awake_cycles_of_all(&r);
  const sim_cycles_t until = r.world->now + span;
  const unsigned loops = load == BENCH_LOAD_CLIENT_LOOP ? bench_client_loops(&r, servos, until)
                                                        : bench_back_to_back(&r, servos, until, load == BENCH_LOAD_GARBAGE, NULL);
  printf(", \"loops\": %u, \"loop_awake_cycles\": %llu, ", loops,
         (unsigned long long)(awake_cycles_of_all(&r) - awake));
  print_cycle_profile("loop", word_cycles, words);
  printf("}\n");
  for (size_t i = 0; i < r.world->servo_count; i++) {
    r.world->servos[i]->pc_cycles = NULL;
  }
  free(word_cycles);
  bench_rig_close(&r);
}

/* Awake share of servo 1 over `span`: 1 - cycles asleep / cycles elapsed. */
static double awake_share_over(bench_rig_t *r, sim_cycles_t span, bool bus_load) {
  const servo_t *s = r->world->servos[0];
  const uint64_t asleep0 = s->sleep_cycles;
  const sim_cycles_t t0 = r->world->now;
  uint8_t p[200];
  unsigned packets = 0;
  while (r->world->now < t0 + span) {
    if (bus_load && r->master->tx_end <= r->world->now + US(200)) {
      master_send(r->master, p, bench_sync_write_goals(p, 30, packets++ / 200, true));
    }
    world_run_until(r->world, r->world->now + US(50));
  }
  return 1.0 - (double)(s->sleep_cycles - asleep0) / (double)(r->world->now - t0);
}

void bench_awake(void) {
  bench_rig_t r;
  bench_rig_open(&r, 1);
  const double idle = awake_share_over(&r, MS(1000), false);
  bench_write_byte(&r, 1, CT_ADDR_TORQUE_ENABLE, 1); /* the control loop holds the position */
  world_run_until(r.world, r.world->now + MS(200));
  const double holding = awake_share_over(&r, MS(1000), false);
  const double loaded = awake_share_over(&r, MS(1000), true);
  printf("{\"awake_idle\": %.4f, \"awake_control_loop\": %.4f, \"awake_full_bus_load\": %.4f}\n", idle, holding,
         loaded);
  bench_rig_close(&r);
}

