/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The real-time policy's guard (model/host/rt_guard.c) on a simulated clock: a pacing thread
 * behind the clock yields its CPU every RT_GUARD_RUN_MAX_US, drops the policy after
 * RT_GUARD_LATE_MAX_US late and takes it again only once on time for RT_GUARD_ON_TIME_US (or on
 * probation), whatever the re-alignments of the clocks do; one that keeps time keeps it. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "rt_guard.h"

/* A pacing thread checked every step_us for duration_us, late by lag(t) (negative ahead), never
 * blocking but to yield; records the longest run it made without blocking while it held the
 * policy. The lag model: `speed` simulated seconds per wall second, the lag dropped (re-aligned)
 * past 200 ms as pacing does. */
typedef struct {
  double now_us;
  double lag_us;
  double longest_run_us;
  double run_start_us;
  uint64_t retakes;
} run_t;

static void run_behind(rt_guard_t *g, run_t *r, double speed, double duration_us, double step_us) {
  const double end = r->now_us + duration_us;
  while (r->now_us < end) {
    r->now_us += step_us;
    r->lag_us += step_us * (1.0 - speed);
    if (r->lag_us > 200000.0) {
      r->lag_us = 0.0; /* re-aligned: on time for a moment without having caught up */
      rt_guard_realigned(g, r->now_us);
    }
    const bool held_before = g->held;
    switch (rt_guard_check(g, r->now_us, -r->lag_us, false)) {
      case RT_GUARD_YIELD:
        r->now_us += RT_GUARD_YIELD_US;
        r->lag_us += RT_GUARD_YIELD_US;
        rt_guard_blocked(g, r->now_us);
        r->run_start_us = r->now_us;
        break;
      case RT_GUARD_RETAKE: r->retakes++; r->run_start_us = r->now_us; break;
      default: break;
    }
    if (held_before && g->held && r->now_us - r->run_start_us > r->longest_run_us) {
      r->longest_run_us = r->now_us - r->run_start_us;
    }
  }
}

static void test_a_thread_behind_yields_every_run_max(void **state) {
  (void)state;
  rt_guard_t g;
  rt_guard_start(&g, 0.0);
  run_t r = {0};
  run_behind(&g, &r, 0.9, 500000.0, 100.0); /* half a second at 0.9x: late, not yet dropped */
  assert_true(g.held);
  assert_true(r.longest_run_us <= RT_GUARD_RUN_MAX_US + 100.0);
  assert_true(g.yields >= 500000.0 / (RT_GUARD_RUN_MAX_US + RT_GUARD_YIELD_US) - 1.0);
}

static void test_a_world_too_slow_even_so_drops_the_policy_and_keeps_it_dropped(void **state) {
  (void)state;
  for (double speed = 0.2; speed < 0.99; speed += 0.1) {
    rt_guard_t g;
    rt_guard_start(&g, 0.0);
    run_t r = {0};
    run_behind(&g, &r, speed, RT_GUARD_LATE_MAX_US + RT_GUARD_LATE_US / (1.0 - speed) + 1000.0, 100.0);
    assert_false(g.held); /* dropped once late for RT_GUARD_LATE_MAX_US, re-alignments or not */
    assert_int_equal(g.drops, 1);
    run_behind(&g, &r, speed, RT_GUARD_RETRY_US - 2e6, 100.0);
    assert_false(g.held); /* the on-time moments after re-alignments do not take it again */
    assert_int_equal(r.retakes, 0);
  }
}

static void test_a_hopeless_world_holds_the_policy_a_tenth_of_the_time(void **state) {
  (void)state;
  rt_guard_t g;
  rt_guard_start(&g, 0.0);
  run_t r = {0};
  double held_us = 0.0;
  for (int i = 0; i < 60000; i++) { /* a minute at 0.5x, step by step */
    const bool held = g.held;
    run_behind(&g, &r, 0.5, 1000.0, 100.0);
    held_us += held ? 1000.0 : 0.0;
  }
  /* On probation every RT_GUARD_RETRY_US, dropped again after RT_GUARD_LATE_MAX_US. */
  assert_true(g.drops >= 5 && g.drops <= 6);
  assert_true(held_us <= 60e6 * (RT_GUARD_LATE_MAX_US + 1e5) / (RT_GUARD_LATE_MAX_US + RT_GUARD_RETRY_US));
}

static void test_a_world_that_catches_up_takes_the_policy_again(void **state) {
  (void)state;
  rt_guard_t g;
  rt_guard_start(&g, 0.0);
  run_t r = {0};
  run_behind(&g, &r, 0.5, 1.5e6, 100.0); /* a burst the host could not carry */
  assert_false(g.held);
  r.lag_us = 0.0; /* caught up (not a re-alignment) */
  run_behind(&g, &r, 1.0, RT_GUARD_ON_TIME_US - 1000.0, 100.0);
  assert_false(g.held); /* not yet: on time for less than RT_GUARD_ON_TIME_US */
  run_behind(&g, &r, 1.0, RT_GUARD_REALIGN_GRACE_US + 2000.0, 100.0);
  assert_true(g.held);
  assert_int_equal(r.retakes, 1);
  assert_true(g.dropped_us >= 0.5e6 && g.dropped_us <= 1.0e6);
}

static void test_a_thread_on_time_that_sleeps_is_left_alone(void **state) {
  (void)state;
  rt_guard_t g;
  rt_guard_start(&g, 0.0);
  double now = 0.0;
  for (int i = 0; i < 100000; i++) { /* 10 s: run 80 us, sleep 20 us ahead of the clock */
    now += 80.0;
    assert_int_equal(rt_guard_check(&g, now, 20.0, true), RT_GUARD_RUN);
    now += 20.0;
    rt_guard_blocked(&g, now);
  }
  /* Late by less than RT_GUARD_LATE_US on and off (wake-up latency): still held, no yields. */
  for (int i = 0; i < 20000; i++) {
    now += 100.0;
    assert_int_equal(rt_guard_check(&g, now, (i % 2) ? -900.0 : 30.0, (i % 2) == 0), RT_GUARD_RUN);
    if (i % 2 == 0) {
      rt_guard_blocked(&g, now);
    }
  }
  assert_true(g.held);
  assert_int_equal(g.yields, 0);
  assert_int_equal(g.drops, 0);
}

static void test_a_world_late_now_and_then_keeps_the_policy(void **state) {
  (void)state;
  rt_guard_t g;
  rt_guard_start(&g, 0.0);
  double now = 0.0;
  for (int i = 0; i < 200000; i++) { /* 20 s: every 30 ms a 2 ms hiccup (a busy host's CPU taken) */
    now += 100.0;
    const bool hiccup = (i % 300) < 20;
    const rt_guard_action_t a = rt_guard_check(&g, now, hiccup ? -2000.0 : 30.0, !hiccup);
    assert_true(a == RT_GUARD_RUN || a == RT_GUARD_YIELD);
    if (!hiccup) {
      rt_guard_blocked(&g, now);
    }
  }
  assert_true(g.held);
  assert_int_equal(g.drops, 0);
}

static void test_a_thread_that_may_not_take_it_again_stays_ordinary(void **state) {
  (void)state;
  rt_guard_t g;
  rt_guard_start(&g, 0.0);
  run_t r = {0};
  run_behind(&g, &r, 0.5, 1.5e6, 100.0);
  assert_false(g.held);
  rt_guard_give_up(&g);
  r.lag_us = 0.0;
  run_behind(&g, &r, 1.0, 2 * RT_GUARD_RETRY_US, 100.0);
  assert_false(g.held);
  assert_int_equal(r.retakes, 0);
}

/* A boot slower than real time may drop the policy; the serving after it (rt_guard_restart, at
 * `ready:`) starts at the policy again, its counts from zero, and drops it only after a late
 * spell of its own. */
static void test_a_policy_dropped_during_the_boot_is_taken_again_for_the_serving(void **state) {
  (void)state;
  rt_guard_t g;
  rt_guard_start(&g, 0.0);
  run_t r = {0};
  run_behind(&g, &r, 0.05, 2.0 * RT_GUARD_LATE_MAX_US, 100.0); /* the boot: far behind */
  assert_false(g.held);
  assert_true(g.drops >= 1);
  assert_true(rt_guard_restart(&g, r.now_us));
  assert_true(g.held);
  assert_int_equal(g.drops, 0);
  assert_int_equal(g.yields, 0);
  assert_false(rt_guard_restart(&g, r.now_us)); /* held: nothing to take again */
  r.lag_us = 0.0;
  run_behind(&g, &r, 0.05, RT_GUARD_LATE_MAX_US / 2.0, 100.0); /* serving behind: yields first */
  assert_true(g.held);
  assert_true(g.yields > 0);
  run_behind(&g, &r, 0.05, RT_GUARD_LATE_MAX_US, 100.0); /* then drops after its own spell */
  assert_false(g.held);
  assert_int_equal(g.drops, 1);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_a_thread_behind_yields_every_run_max),
      cmocka_unit_test(test_a_world_too_slow_even_so_drops_the_policy_and_keeps_it_dropped),
      cmocka_unit_test(test_a_hopeless_world_holds_the_policy_a_tenth_of_the_time),
      cmocka_unit_test(test_a_world_that_catches_up_takes_the_policy_again),
      cmocka_unit_test(test_a_thread_on_time_that_sleeps_is_left_alone),
      cmocka_unit_test(test_a_world_late_now_and_then_keeps_the_policy),
      cmocka_unit_test(test_a_thread_that_may_not_take_it_again_stays_ordinary),
      cmocka_unit_test(test_a_policy_dropped_during_the_boot_is_taken_again_for_the_serving),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
