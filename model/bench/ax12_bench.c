// SPDX-License-Identifier: GPL-3.0-or-later
/* ax12-bench: the figures of scripts/bench that come from simulated cycles (exact), printed
 * as one JSON object on stdout. Wall-clock figures (simulation speed) are measured here too,
 * once per call; scripts/bench takes medians over several calls.
 *
 *   ax12-bench turnaround ELF [REQUESTS]   reply start after the request's stop bit, RDT 0
 *   ax12-bench rdt ELF                     reply start error against 2 us x RDT
 *   ax12-bench sustained ELF SERVOS SECONDS back-to-back SYNC_WRITE at 1 Mbps: bytes lost
 *   ax12-bench speed ELF SERVOS SECONDS    simulated seconds per wall second, idle and loaded
 *   ax12-bench stack ELF                   deepest stack after a workload of every instruction
 *   ax12-bench awake ELF                   share of cycles the MCU is awake: idle, holding
 *                                          a position (control loop alone), full bus load
 *   ax12-bench profile ELF SERVOS SECONDS  awake cycles by instruction address, holding and
 *                                          under the client loop (scripts/firmware_profile)
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <sim_avr.h>

#include "elf_symbols.h"
#include "master.h"
#include "servo.h"
#include "world.h"

#define US(x) ((sim_cycles_t)(x) * SIM_CYCLES_PER_US)
#define MS(x) US((x) * 1000u)
#define REPLY_TIMEOUT MS(150)

static const char *elf_path;

static double wall_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + (double)t.tv_nsec / 1e9;
}

static void die(const char *what, const char *detail) {
  fprintf(stderr, "ax12-bench: %s%s%s\n", what, detail ? ": " : "", detail ? detail : "");
  exit(1);
}

/* Checksums are written here from the manual, independently of the firmware. */
static size_t packet(uint8_t *out, uint8_t id, uint8_t instruction, const uint8_t *params, size_t count) {
  out[0] = 0xFF;
  out[1] = 0xFF;
  out[2] = id;
  out[3] = (uint8_t)(count + 2);
  out[4] = instruction;
  unsigned sum = id + out[3] + instruction;
  for (size_t i = 0; i < count; i++) {
    out[5 + i] = params[i];
    sum += params[i];
  }
  out[5 + count] = (uint8_t)~sum;
  return count + 6;
}

typedef struct {
  world_t *world;
  master_t *master;
} rig_t;

static void rig_open(rig_t *r, unsigned servos) {
  char err[512];
  r->world = world_create(elf_path, strstr(elf_path, "atmega328p") ? "atmega328p" : "atmega88",
                          strstr(elf_path, "ax12a-") ? EEPROM_PROFILE_AX12A : EEPROM_PROFILE_AX12, err, sizeof err);
  if (!r->world) die("cannot load the firmware", err);
  for (unsigned id = 1; id <= servos; id++) {
    if (!world_add_servo(r->world, (uint8_t)id, 1, NULL, err, sizeof err)) die("cannot add a servo", err);
  }
  r->master = master_create(r->world, 1e6);
  if (!r->master) die("cannot add the master", NULL);
  world_run_until(r->world, r->world->now + MS(300)); /* power-up: LED blinks, ADC settles */
}

static void rig_close(rig_t *r) {
  master_destroy(r->master);
  world_destroy(r->world);
}

/* Sends a packet; returns the cycles from its last stop bit to the start of the first byte
 * heard back (0 if none came within REPLY_TIMEOUT), and lets the reply finish. */
static sim_cycles_t exchange(rig_t *r, const uint8_t *bytes, size_t count, size_t expect_bytes) {
  master_rx_clear(r->master);
  const sim_cycles_t end = master_send(r->master, bytes, count);
  sim_cycles_t start = 0;
  while (r->world->now < end + REPLY_TIMEOUT) {
    world_run_until(r->world, r->world->now + US(5));
    if (master_rx_count(r->master) >= (expect_bytes ? expect_bytes : 1)) break;
  }
  if (master_rx_count(r->master) > 0) start = master_rx(r->master, 0)->start;
  world_run_until(r->world, r->world->now + US(200));
  return start ? start - end : 0;
}

static void write_byte(rig_t *r, uint8_t id, uint8_t addr, uint8_t value) {
  uint8_t p[8], params[2] = {addr, value};
  if (exchange(r, p, packet(p, id, 0x03, params, 2), 6) == 0) die("no reply to a WRITE", NULL);
}

static int compare_cycles(const void *a, const void *b) {
  const sim_cycles_t x = *(const sim_cycles_t *)a, y = *(const sim_cycles_t *)b;
  return x < y ? -1 : x > y;
}

/* Moves the start of the next request to a pseudo-random phase of the firmware's timers. */
static void idle_random(rig_t *r, unsigned *seed) {
  *seed = *seed * 1103515245u + 12345u;
  world_run_until(r->world, r->world->now + US(300) + (*seed >> 8) % 20000u);
}

static void turnaround(unsigned requests) {
  rig_t r;
  rig_open(&r, 1);
  write_byte(&r, 1, 5, 0); /* Return Delay Time 0 */
  static const struct { const char *name; uint8_t instruction; uint8_t params[3]; size_t count; size_t reply; } kinds[] = {
      {"ping", 0x01, {0}, 0, 6},
      {"read2", 0x02, {36, 2}, 2, 8},
      {"write2", 0x03, {30, 0x00, 0x02}, 3, 6},
  };
  sim_cycles_t *samples = calloc(requests, sizeof *samples);
  unsigned seed = 12345;
  printf("{\"requests\": %u", requests);
  for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
    unsigned missing = 0;
    for (unsigned i = 0; i < requests; i++) {
      uint8_t p[16];
      idle_random(&r, &seed);
      samples[i] = exchange(&r, p, packet(p, 1, kinds[k].instruction, kinds[k].params, kinds[k].count), kinds[k].reply);
      missing += samples[i] == 0;
    }
    qsort(samples, requests, sizeof *samples, compare_cycles);
    printf(", \"%s_median_cycles\": %llu, \"%s_min_cycles\": %llu, \"%s_worst_cycles\": %llu, \"%s_missing\": %u",
           kinds[k].name, (unsigned long long)samples[requests / 2], kinds[k].name, (unsigned long long)samples[0],
           kinds[k].name, (unsigned long long)samples[requests - 1], kinds[k].name, missing);
  }
  printf("}\n");
  free(samples);
  rig_close(&r);
}

static void rdt_accuracy(void) {
  static const uint8_t values[] = {1, 2, 5, 10, 50, 100, 250, 254};
  rig_t r;
  rig_open(&r, 1);
  unsigned seed = 777;
  printf("{");
  double worst_us = 0;
  for (size_t v = 0; v < sizeof values; v++) {
    write_byte(&r, 1, 5, values[v]);
    double worst_error_us = 0, worst_read_error_us = 0;
    for (int i = 0; i < 40; i++) {
      uint8_t p[8];
      static const uint8_t read_position[2] = {36, 2};
      const bool read = i % 2 == 1;
      idle_random(&r, &seed);
      const sim_cycles_t latency =
          read ? exchange(&r, p, packet(p, 1, 0x02, read_position, 2), 8) : exchange(&r, p, packet(p, 1, 0x01, NULL, 0), 6);
      const double error_us = ((double)latency - (double)US(2u * values[v])) / SIM_CYCLES_PER_US;
      if (latency == 0) die("no reply", NULL);
      double *worst = read ? &worst_read_error_us : &worst_error_us;
      if (error_us * error_us > *worst * *worst) *worst = error_us;
    }
    printf("%s\"rdt_%u_worst_error_us\": %.3f, \"rdt_%u_read_worst_error_us\": %.3f", v ? ", " : "", values[v],
           worst_error_us, values[v], worst_read_error_us);
    if (worst_error_us * worst_error_us > worst_us * worst_us) worst_us = worst_error_us;
  }
  printf(", \"rdt_worst_error_us\": %.3f}\n", worst_us);
  rig_close(&r);
}

/* A RAM counter of the firmware, by symbol (-1 when the ELF does not have it). */
static long firmware_counter(const servo_t *s, const char *symbol, unsigned bytes) {
  uint32_t address;
  if (!elf_symbol_address(elf_path, symbol, &address)) return -1;
  long value = 0;
  for (unsigned i = 0; i < bytes; i++) value |= (long)s->avr->data[address + i] << (8 * i);
  return value;
}

/* A SYNC_WRITE to every servo from address 30: Goal Position only (2 bytes each, the issue's
 * client loop, LENGTH 94 for 30 servos), or Goal Position and Moving Speed 0 (4 bytes each,
 * 158 bytes for 30: the longest packet of the sustained load). */
static size_t sync_write_goals(uint8_t *out, unsigned servos, unsigned phase, bool with_speed) {
  uint8_t params[2 + 5 * 32];
  size_t n = 0;
  params[n++] = 30; /* Goal Position, Moving Speed */
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
  return packet(out, 0xFE, 0x83, params, n);
}

static void sustained(unsigned servos, double seconds) {
  rig_t r;
  rig_open(&r, servos);
  long dropped_before = 0, ticks_before = 0, control_before = 0;
  for (size_t i = 0; i < r.world->servo_count; i++) {
    dropped_before += firmware_counter(r.world->servos[i], "uart_rx_dropped_count", 1);
    ticks_before += firmware_counter(r.world->servos[i], "timebase_ms_count", 2);
    control_before += firmware_counter(r.world->servos[i], "control_tick_count", 2);
  }
  uint64_t overruns_before = 0;
  for (size_t i = 0; i < r.world->servo_count; i++) overruns_before += r.world->servos[i]->board.link.rx_overruns;
  uint8_t p[200];
  const sim_cycles_t t0 = r.world->now, until = t0 + (sim_cycles_t)(seconds * 1e6 * SIM_CYCLES_PER_US);
  unsigned packets = 0;
  size_t bytes = 0;
  while (r.world->now < until) {
    if (r.master->tx_end <= r.world->now + US(200)) { /* keep the wire busy: no gap */
      const size_t n = sync_write_goals(p, servos, packets / 200, true);
      master_send(r.master, p, n);
      packets++;
      bytes += n;
    }
    world_run_until(r.world, r.world->now + US(50));
  }
  world_run_until(r.world, r.master->tx_end);
  const double elapsed_ms = (double)(r.world->now - t0) / SIM_CYCLES_PER_US / 1000.0;
  long dropped = -dropped_before, ticks = -ticks_before, control = -control_before;
  uint64_t overruns = 0;
  for (size_t i = 0; i < r.world->servo_count; i++) {
    dropped += firmware_counter(r.world->servos[i], "uart_rx_dropped_count", 1);
    ticks += firmware_counter(r.world->servos[i], "timebase_ms_count", 2);
    control += firmware_counter(r.world->servos[i], "control_tick_count", 2);
    overruns += r.world->servos[i]->board.link.rx_overruns;
  }
  overruns -= overruns_before;
  /* Check the last SYNC_WRITE landed: read every goal back after the load. */
  unsigned wrong_goals = 0;
  world_run_until(r.world, r.world->now + MS(5));
  const unsigned phase = (packets - 1) / 200;
  for (unsigned id = 1; id <= servos; id++) {
    uint8_t q[8], params[2] = {30, 2}, reply[8];
    exchange(&r, q, packet(q, (uint8_t)id, 0x02, params, 2), 8);
    const size_t got = master_rx_values(r.master, reply, sizeof reply);
    const unsigned goal = (phase & 1) ? 300 + id * 10 : 700 - id * 10;
    wrong_goals += !(got == 8 && (unsigned)(reply[5] | reply[6] << 8) == goal);
  }
  const long expected_ticks = (long)elapsed_ms * (long)servos; /* whole milliseconds: each servo may count one more */
  printf("{\"servos\": %u, \"simulated_s\": %.3f, \"packets\": %u, \"bytes\": %zu, \"wire_busy_fraction\": %.4f, "
         "\"bytes_lost_uart_overrun\": %llu, \"bytes_dropped_by_firmware\": %ld, \"goals_wrong_after_load\": %u, "
         "\"timer_ticks\": %ld, \"timer_ticks_expected\": %ld, \"control_ticks_run\": %ld}\n",
         servos, elapsed_ms / 1000.0, packets, bytes, (double)bytes * 10.0 / (elapsed_ms * 1000.0),
         (unsigned long long)overruns, dropped < 0 ? -1 : dropped, wrong_goals, ticks, expected_ticks,
         control_before < 0 ? -1 : control);
  rig_close(&r);
}

/* The client loop of the issue: one SYNC_WRITE of goal positions, then a READ of Present
 * Position from every servo, waiting for each reply. Returns loops completed. */
static unsigned client_loops(rig_t *r, unsigned servos, sim_cycles_t until) {
  unsigned loops = 0;
  uint8_t p[200];
  while (r->world->now < until) {
    const size_t n = sync_write_goals(p, servos, loops / 50, false);
    master_send(r->master, p, n);
    for (unsigned id = 1; id <= servos; id++) {
      uint8_t q[8], params[2] = {36, 2};
      exchange(r, q, packet(q, (uint8_t)id, 0x02, params, 2), 8);
    }
    loops++;
  }
  return loops;
}

/* Torque on in servos 1..servos (one SYNC_WRITE), as the SDK loop (scripts/bench.py) does:
 * the servos hold and move. */
static void torque_on_all(rig_t *r, unsigned servos) {
  uint8_t torque_on[2 + 2 * 32];
  size_t n = 0;
  torque_on[n++] = 24;
  torque_on[n++] = 1;
  for (unsigned id = 1; id <= servos; id++) {
    torque_on[n++] = (uint8_t)id;
    torque_on[n++] = 1;
  }
  uint8_t p[80];
  master_send(r->master, p, packet(p, 0xFE, 0x83, torque_on, n));
}

static void speed(unsigned servos, double seconds) {
  rig_t r;
  rig_open(&r, servos);
  const sim_cycles_t span = (sim_cycles_t)(seconds * 1e6 * SIM_CYCLES_PER_US);
  double w0 = wall_s();
  world_run_until(r.world, r.world->now + span);
  const double idle_speed = seconds / (wall_s() - w0);
  torque_on_all(&r, servos);
  w0 = wall_s();
  const sim_cycles_t t0 = r.world->now;
  const unsigned loops = client_loops(&r, servos, t0 + span);
  const double loaded_wall = wall_s() - w0;
  const double loaded_sim = (double)(r.world->now - t0) / SIM_CYCLES_PER_US / 1e6;
  printf("{\"servos\": %u, \"idle_sim_s_per_wall_s\": %.3f, \"loaded_sim_s_per_wall_s\": %.3f, "
         "\"client_loops_per_sim_s\": %.1f}\n",
         servos, idle_speed, loaded_sim / loaded_wall, loops / loaded_sim);
  rig_close(&r);
}

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
static uint64_t awake_cycles_of_all(const rig_t *r) {
  uint64_t awake = 0;
  for (size_t i = 0; i < r->world->servo_count; i++) {
    const servo_t *s = r->world->servos[i];
    awake += s->avr->cycle - s->sleep_cycles;
  }
  return awake;
}

/* Awake cycles by instruction, summed over the servos (scripts/firmware_profile names them):
 * `seconds` holding a position with torque on and no traffic, then `seconds` of the client
 * loop of `speed`. One JSON object. */
static void cycle_profile(unsigned servos, double seconds) {
  rig_t r;
  rig_open(&r, servos);
  (void)world_set_threads(r.world, 1); /* the servos share one array */
  const sim_cycles_t span = (sim_cycles_t)(seconds * 1e6 * SIM_CYCLES_PER_US);
  torque_on_all(&r, servos);
  world_run_until(r.world, r.world->now + MS(100));
  const size_t words = (r.world->servos[0]->avr->flashend + 1u) / 2u;
  uint64_t *word_cycles = calloc(words, sizeof *word_cycles);
  if (!word_cycles) die("out of memory", NULL);
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
  const unsigned loops = client_loops(&r, servos, r.world->now + span);
  printf(", \"loops\": %u, \"loop_awake_cycles\": %llu, ", loops,
         (unsigned long long)(awake_cycles_of_all(&r) - awake));
  print_cycle_profile("loop", word_cycles, words);
  printf("}\n");
  for (size_t i = 0; i < r.world->servo_count; i++) {
    r.world->servos[i]->pc_cycles = NULL;
  }
  free(word_cycles);
  rig_close(&r);
}

/* Awake share of servo 1 over `span`: 1 - cycles asleep / cycles elapsed. */
static double awake_share_over(rig_t *r, sim_cycles_t span, bool bus_load) {
  const servo_t *s = r->world->servos[0];
  const uint64_t asleep0 = s->sleep_cycles;
  const sim_cycles_t t0 = r->world->now;
  uint8_t p[200];
  unsigned packets = 0;
  while (r->world->now < t0 + span) {
    if (bus_load && r->master->tx_end <= r->world->now + US(200)) {
      master_send(r->master, p, sync_write_goals(p, 30, packets++ / 200, true));
    }
    world_run_until(r->world, r->world->now + US(50));
  }
  return 1.0 - (double)(s->sleep_cycles - asleep0) / (double)(r->world->now - t0);
}

static void awake_share(void) {
  rig_t r;
  rig_open(&r, 1);
  const double idle = awake_share_over(&r, MS(1000), false);
  write_byte(&r, 1, 24, 1); /* torque on: the control loop holds the position */
  world_run_until(r.world, r.world->now + MS(200));
  const double holding = awake_share_over(&r, MS(1000), false);
  const double loaded = awake_share_over(&r, MS(1000), true);
  printf("{\"awake_idle\": %.4f, \"awake_control_loop\": %.4f, \"awake_full_bus_load\": %.4f}\n", idle, holding,
         loaded);
  rig_close(&r);
}

#define STACK_PAINT_BYTE 0xC5u /* docs/firmware.md: unused RAM is painted at reset */

static void stack_depth(void) {
  rig_t r;
  rig_open(&r, 30);
  uint8_t p[300];
  static const uint8_t read_all[] = {0, 50}, write_led[] = {25, 1}, reg[] = {30, 0, 2}, id_param[] = {5, 0};
  exchange(&r, p, packet(p, 1, 0x01, NULL, 0), 6);
  exchange(&r, p, packet(p, 1, 0x02, read_all, 2), 56);
  exchange(&r, p, packet(p, 1, 0x03, write_led, 2), 6);
  exchange(&r, p, packet(p, 1, 0x03, id_param, 2), 6);
  exchange(&r, p, packet(p, 1, 0x04, reg, 3), 6);
  exchange(&r, p, packet(p, 1, 0x05, NULL, 0), 6);
  exchange(&r, p, packet(p, 1, 0x07, NULL, 0), 6);                  /* unknown instruction */
  exchange(&r, p, sync_write_goals(p, 30, 0, true), 0);  /* the finder's (LENGTH 154) */
  exchange(&r, p, sync_write_goals(p, 30, 1, false), 0); /* held by the sniff (LENGTH 94) */
  uint8_t bad[] = {0xFF, 0xFF, 1, 2, 1, 0x00};                     /* bad checksum */
  exchange(&r, bad, sizeof bad, 6);
  exchange(&r, p, packet(p, 1, 0x06, NULL, 0), 6);                  /* RESET */
  world_run_until(r.world, r.world->now + MS(200));
  uint16_t statics_end;
  if (!elf_ram_end_of_statics(elf_path, &statics_end)) die("no end-of-statics symbol in the ELF", NULL);
  unsigned deepest = 0;
  for (size_t i = 0; i < r.world->servo_count; i++) {
    const unsigned depth = servo_stack_depth(r.world->servos[i], statics_end, STACK_PAINT_BYTE);
    if (depth > deepest) deepest = depth;
  }
  printf("{\"stack_deepest_bytes\": %u, \"statics_end\": %u}\n", deepest, statics_end);
  rig_close(&r);
}

int main(int argc, char **argv) {
  if (argc < 3) {
    fprintf(stderr, "usage: ax12-bench turnaround|rdt|sustained|speed|stack|awake|profile ELF [args]\n");
    return 2;
  }
  elf_path = argv[2];
  if (strcmp(argv[1], "turnaround") == 0) {
    turnaround(argc > 3 ? (unsigned)atoi(argv[3]) : 200);
  } else if (strcmp(argv[1], "rdt") == 0) {
    rdt_accuracy();
  } else if (strcmp(argv[1], "sustained") == 0 && argc > 4) {
    sustained((unsigned)atoi(argv[3]), atof(argv[4]));
  } else if (strcmp(argv[1], "awake") == 0) {
    awake_share();
  } else if (strcmp(argv[1], "stack") == 0) {
    stack_depth();
  } else if (strcmp(argv[1], "speed") == 0 && argc > 4) {
    speed((unsigned)atoi(argv[3]), atof(argv[4]));
  } else if (strcmp(argv[1], "profile") == 0 && argc > 4) {
    cycle_profile((unsigned)atoi(argv[3]), atof(argv[4]));
  } else {
    fprintf(stderr, "ax12-bench: unknown command or missing arguments\n");
    return 2;
  }
  return 0;
}
