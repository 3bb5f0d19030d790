/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Nothing but speed changes with the fast core (model/simavr/fast_core.h): the same ELF and
 * the same bus traffic run twice, once on simavr's own interpreter (AX12_SIM_CORE=simavr, as
 * `scripts/bench --before` and Debian's libsimavr run it) and once on the fast core, must put
 * the same bytes on the bus at the same cycles (every byte the bus finalizes: start, end,
 * value, sender, collision flags) and write the same waveform trace (the VCD of `serve
 * --trace`, world_trace.h) of the servos that do the scenario's special things.
 *
 * The scenario, 10 simulated seconds of 30 servos at 1 Mbps, one thread: torque on everywhere,
 * then the client loop (a SYNC_WRITE of goal positions, alternating every 25 loops so
 * that the servos move, then a READ of Present Position from each); servo 3 gets an Alarm LED
 * mask and a CCW Angle Limit below its goals (EEPROM stores, then Angle Limit alarms in its
 * replies and its LED on); at 4 s servo 7's control tick interrupt is switched off from
 * outside (TIMSK1 cleared, a fault injected by the host) and the client stops reading it for
 * 500 ms (a reply it arms would switch the tick back on), so its main loop stops feeding the
 * watchdog, which resets it 250 ms later; it comes back and answers again. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include <sim_avr.h>

#include "dxl_protocol.h"
#include "dxl_table.h"
#include "packet_encode.h"
#include "sim_harness.h"
#include "world_trace.h"

#define SERVOS 30u
#define LOOP_SECONDS 10u
#define ALARM_ID 3u
#define RESET_ID 7u
#define RESET_AT_MS 4000u
#define UNREAD_MS 500u
#define TIMSK1_ADDR 0x6Fu /* ATmega88/328P data address */
#define US(x) ((sim_cycles_t)(x) * SIM_CYCLES_PER_US)
#define MS(x) US((x) * 1000u)

static const master_wait_t wait = {.poll_step = US(5),
                                   .reply_timeout = MS(20),
                                   .quiet_after = US(200),
                                   .talk_limit = US(200),
                                   .silence = MS(20)};

typedef struct {
  bus_tap_byte_t *bytes;
  size_t count, cap;
} tap_log_t;

static void tap(void *ctx, const bus_tap_byte_t *byte) {
  tap_log_t *log = ctx;
  if (log->count == log->cap) {
    log->cap = log->cap ? log->cap * 2 : 65536;
    log->bytes = realloc(log->bytes, log->cap * sizeof(*log->bytes));
    assert_non_null(log->bytes);
  }
  log->bytes[log->count++] = *byte;
}

typedef struct {
  tap_log_t bus;
  char vcd[256];
  unsigned loops;
  unsigned alarm_replies;   /* replies of ALARM_ID with the Angle Limit error bit */
  uint64_t watchdog_resets; /* of RESET_ID */
  unsigned answers_after_reset;
} run_t;

static void send_and_wait(master_requester_t *rq, const uint8_t *p, size_t n, size_t expect, uint8_t *reply) {
  (void)master_exchange(rq, p, n, expect, reply, expect);
}

static void run_scenario(const char *core, run_t *out) {
  memset(out, 0, sizeof(*out));
  assert_int_equal(setenv("AX12_SIM_CORE", core, 1), 0);
  char err[512];
  const char *elf = harness_elf_path("ax12", "atmega88");
  world_t *world = world_create(elf, "atmega88", EEPROM_PROFILE_AX12, err, sizeof err);
  if (!world) {
    if (!AX12_FIRMWARE_REQUIRED) {
      skip();
    }
    fail_msg("%s", err);
  }
  (void)world_set_threads(world, 1);
  for (unsigned id = 1; id <= SERVOS; id++) {
    assert_non_null(world_add_servo(world, (uint8_t)id, 1, NULL, err, sizeof err));
  }
  const bool fast = strcmp(core, "simavr") != 0;
  for (unsigned i = 0; i < SERVOS; i++) {
    assert_int_equal(world->servos[i]->fast_core != NULL, fast); /* the core asked for runs */
  }
  master_t *master = world_add_master(world, 1e6);
  assert_non_null(master);
  master_requester_t rq = world_requester(world, master, wait);
  bus_set_tap(&world->bus, tap, &out->bus);
  bool traced[SERVOS] = {false};
  traced[0] = traced[ALARM_ID - 1] = traced[RESET_ID - 1] = traced[SERVOS - 1] = true;
  snprintf(out->vcd, sizeof out->vcd, "/tmp/ax12-core-differential-%d-%s.vcd", (int)getpid(), core);
  world_trace_t *trace = world_trace_open(world, out->vcd, traced, err, sizeof err);
  assert_non_null(trace);

  world_run_until(world, world->now + MS(300)); /* power-up */
  uint8_t p[200], reply[16];
  uint8_t params[2 + 2 * SERVOS];
  size_t n = 0;
  params[n++] = CT_ADDR_TORQUE_ENABLE;
  params[n++] = 1;
  for (unsigned id = 1; id <= SERVOS; id++) {
    params[n++] = (uint8_t)id;
    params[n++] = 1;
  }
  send_and_wait(&rq, p, packet_encode(p, DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE, params, n), 0, reply);
  const uint8_t alarm_led[2] = {CT_ADDR_ALARM_LED, 0x7F};
  send_and_wait(&rq, p, packet_encode(p, ALARM_ID, DXL_INST_WRITE, alarm_led, 2), 6, reply);
  const uint8_t ccw_limit[3] = {CT_ADDR_CCW_ANGLE_LIMIT, 600 & 0xFF, 600 >> 8};
  send_and_wait(&rq, p, packet_encode(p, ALARM_ID, DXL_INST_WRITE, ccw_limit, 3), 6, reply);

  const sim_cycles_t start = world->now, end = start + MS(LOOP_SECONDS * 1000u);
  bool poked = false;
  while (world->now < end) {
    if (!poked && world->now >= start + MS(RESET_AT_MS)) {
      world->servos[RESET_ID - 1]->avr->data[TIMSK1_ADDR] = 0; /* the tick stops: no watchdog feed */
      poked = true;
    }
    uint8_t goals[2 + 3 * SERVOS];
    size_t g = 0;
    goals[g++] = CT_ADDR_GOAL_POSITION;
    goals[g++] = 2;
    for (unsigned id = 1; id <= SERVOS; id++) {
      const unsigned goal = ((out->loops / 25u) & 1u) ? 300 + id * 10 : 700 - id * 10;
      goals[g++] = (uint8_t)id;
      goals[g++] = (uint8_t)(goal & 0xFF);
      goals[g++] = (uint8_t)(goal >> 8);
    }
    master_send(master, p, packet_encode(p, DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE, goals, g));
    const bool unread = poked && world->now < start + MS(RESET_AT_MS + UNREAD_MS);
    for (unsigned id = 1; id <= SERVOS; id++) {
      if (id == RESET_ID && unread) {
        continue;
      }
      const uint8_t read[2] = {CT_ADDR_PRESENT_POSITION, 2};
      memset(reply, 0, sizeof reply);
      const master_reply_t r =
          master_exchange(&rq, p, packet_encode(p, (uint8_t)id, DXL_INST_READ, read, 2), 8, reply, 8);
      if (id == ALARM_ID && r.received == 8 && (reply[4] & 0x02)) {
        out->alarm_replies++;
      }
      if (id == RESET_ID && r.received == 8 && world->servos[RESET_ID - 1]->watchdog_resets > 0) {
        out->answers_after_reset++;
      }
    }
    out->loops++;
    world_trace_commit(trace);
  }
  out->watchdog_resets = world->servos[RESET_ID - 1]->watchdog_resets;
  assert_int_equal(world_trace_close(trace), 0);
  master_destroy(master);
  world_destroy(world);
  unsetenv("AX12_SIM_CORE");
}

/* Equal files apart from the VCD's $date line. */
static void expect_same_vcd(const char *a_path, const char *b_path) {
  FILE *a = fopen(a_path, "r"), *b = fopen(b_path, "r");
  assert_non_null(a);
  assert_non_null(b);
  char *la = NULL, *lb = NULL;
  size_t ca = 0, cb = 0;
  unsigned long line = 0, changes = 0;
  for (;;) {
    const ssize_t na = getline(&la, &ca, a), nb = getline(&lb, &cb, b);
    line++;
    if (na < 0 || nb < 0) {
      assert_true(na < 0 && nb < 0); /* both end together */
      break;
    }
    if (strncmp(la, "$date", 5) == 0 && strncmp(lb, "$date", 5) == 0) {
      continue;
    }
    changes += la[0] != '#' && la[0] != '$';
    if (na != nb || memcmp(la, lb, (size_t)na) != 0) {
      fail_msg("VCD line %lu differs: simavr '%.*s' / fast '%.*s'", line, (int)na - 1, la, (int)nb - 1, lb);
    }
  }
  print_message("VCD: %lu lines alike, %lu value changes\n", line, changes);
  assert_true(changes > 10000u); /* the traced servos drove their pins */
  free(la);
  free(lb);
  fclose(a);
  fclose(b);
}

static void test_fast_core_changes_nothing_but_speed(void **state) {
  (void)state;
  run_t stock, fast;
  run_scenario("simavr", &stock);
  run_scenario("fast", &fast);
  print_message("%u client loops, %zu bytes on the bus, %u replies with the Angle Limit alarm, %llu watchdog "
                "reset(s), %u answers after it\n",
                fast.loops, fast.bus.count, fast.alarm_replies, (unsigned long long)fast.watchdog_resets,
                fast.answers_after_reset);
  /* The scenario did what it is for (in both runs, since they must be the same). */
  assert_true(fast.loops > 300u);
  assert_true(fast.alarm_replies > 50u);
  assert_true(fast.watchdog_resets >= 1u);
  assert_true(fast.answers_after_reset > 100u);
  assert_int_equal(stock.loops, fast.loops);
  assert_int_equal(stock.alarm_replies, fast.alarm_replies);
  assert_int_equal(stock.watchdog_resets, fast.watchdog_resets);
  assert_int_equal(stock.bus.count, fast.bus.count);
  for (size_t i = 0; i < fast.bus.count; i++) {
    const bus_tap_byte_t *a = &stock.bus.bytes[i], *b = &fast.bus.bytes[i];
    if (a->start != b->start || a->end != b->end || a->sent != b->sent || a->wire != b->wire ||
        a->flags != b->flags || a->sender != b->sender) {
      fail_msg("bus byte %zu differs: simavr %02x from node %u at %llu / fast %02x from node %u at %llu", i, a->sent,
               a->sender, (unsigned long long)a->start, b->sent, b->sender, (unsigned long long)b->start);
    }
  }
  expect_same_vcd(stock.vcd, fast.vcd);
  unlink(stock.vcd);
  unlink(fast.vcd);
  free(stock.bus.bytes);
  free(fast.bus.bytes);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_fast_core_changes_nothing_but_speed),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
