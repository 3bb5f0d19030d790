/* SPDX-License-Identifier: GPL-3.0-or-later */
#include <stdio.h>
#include <stdbool.h>
#include <stdlib.h>

#include "dxl_protocol.h"
#include "dxl_table.h"

#include "bench_commands.h"
#include "bench_rig.h"

/* Reply timing: the start of a reply after the request's last stop bit, against 2 us x the
 * Return Delay Time. */

static int compare_cycles(const void *a, const void *b) {
  const sim_cycles_t x = *(const sim_cycles_t *)a, y = *(const sim_cycles_t *)b;
  return x < y ? -1 : x > y;
}

/* Moves the start of the next request to a pseudo-random phase of the firmware's timers
 * (300..1550 us of idle bus). */
static void idle_random(bench_rig_t *r, unsigned *seed) {
  *seed = *seed * 1103515245u + 12345u;
  world_run_until(r->world, r->world->now + US(300) + (*seed >> 8) % 20000u);
}

void bench_turnaround(unsigned requests) {
  bench_rig_t r;
  bench_rig_open(&r, 1);
  bench_write_byte(&r, 1, CT_ADDR_RETURN_DELAY_TIME, 0);
  static const struct { const char *name; uint8_t instruction; uint8_t params[3]; size_t count; size_t reply; } kinds[] = {
      {"ping", DXL_INST_PING, {0}, 0, 6},
      {"read2", DXL_INST_READ, {CT_ADDR_PRESENT_POSITION, 2}, 2, 8},
      {"write2", DXL_INST_WRITE, {CT_ADDR_GOAL_POSITION, 0x00, 0x02}, 3, 6},
  };
  sim_cycles_t *samples = calloc(requests, sizeof *samples);
  unsigned seed = 12345;
  printf("{\"requests\": %u", requests);
  for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
    unsigned missing = 0;
    for (unsigned i = 0; i < requests; i++) {
      uint8_t p[16];
      idle_random(&r, &seed);
      samples[i] = bench_exchange(&r, p, packet_encode(p, 1, kinds[k].instruction, kinds[k].params, kinds[k].count), kinds[k].reply);
      missing += samples[i] == 0;
    }
    qsort(samples, requests, sizeof *samples, compare_cycles);
    printf(", \"%s_median_cycles\": %llu, \"%s_min_cycles\": %llu, \"%s_worst_cycles\": %llu, \"%s_missing\": %u",
           kinds[k].name, (unsigned long long)samples[requests / 2], kinds[k].name, (unsigned long long)samples[0],
           kinds[k].name, (unsigned long long)samples[requests - 1], kinds[k].name, missing);
  }
  printf("}\n");
  free(samples);
  bench_rig_close(&r);
}

void bench_rdt(void) {
  static const uint8_t values[] = {1, 2, 5, 10, 50, 100, 250, 254};
  bench_rig_t r;
  bench_rig_open(&r, 1);
  unsigned seed = 777;
  printf("{");
  double worst_us = 0;
  for (size_t v = 0; v < sizeof values; v++) {
    bench_write_byte(&r, 1, CT_ADDR_RETURN_DELAY_TIME, values[v]);
    double worst_error_us = 0, worst_read_error_us = 0;
    for (int i = 0; i < 40; i++) {
      uint8_t p[8];
      static const uint8_t read_position[2] = {CT_ADDR_PRESENT_POSITION, 2};
      const bool read = i % 2 == 1;
      idle_random(&r, &seed);
      const sim_cycles_t latency =
          read ? bench_exchange(&r, p, packet_encode(p, 1, DXL_INST_READ, read_position, 2), 8) : bench_exchange(&r, p, packet_encode(p, 1, DXL_INST_PING, NULL, 0), 6);
      const double error_us = ((double)latency - (double)US(2u * values[v])) / SIM_CYCLES_PER_US;
      if (latency == 0) bench_die("no reply", NULL);
      double *worst = read ? &worst_read_error_us : &worst_error_us;
      if (error_us * error_us > *worst * *worst) *worst = error_us;
    }
    printf("%s\"rdt_%u_worst_error_us\": %.3f, \"rdt_%u_read_worst_error_us\": %.3f", v ? ", " : "", values[v],
           worst_error_us, values[v], worst_read_error_us);
    if (worst_error_us * worst_error_us > worst_us * worst_us) worst_us = worst_error_us;
  }
  printf(", \"rdt_worst_error_us\": %.3f}\n", worst_us);
  bench_rig_close(&r);
}

