/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "world_threads.h"

#include <linux/futex.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/syscall.h>
#include <unistd.h>

#include "servo_run.h"

/* Polls of the other side's counter before sleeping on its futex (a step takes microseconds). */
#define WORLD_SPIN 20000

static void futex_wait(uint32_t *word, uint32_t value) {
  (void)syscall(SYS_futex, word, FUTEX_WAIT_PRIVATE, value, NULL, NULL, 0);
}

static void futex_wake(uint32_t *word) { (void)syscall(SYS_futex, word, FUTEX_WAKE_PRIVATE, 1, NULL, NULL, 0); }

/* Waits until *word != value; *sleeping tells the other side to wake it. */
static uint32_t await_change(uint32_t *word, uint32_t value, uint32_t *sleeping, const bool *park) {
  for (int i = 0; i < WORLD_SPIN && !(park && __atomic_load_n(park, __ATOMIC_RELAXED)); i++) {
    const uint32_t now = __atomic_load_n(word, __ATOMIC_ACQUIRE);
    if (now != value) {
      return now;
    }
    __builtin_ia32_pause();
  }
  for (;;) {
    __atomic_store_n(sleeping, 1u, __ATOMIC_SEQ_CST);
    const uint32_t now = __atomic_load_n(word, __ATOMIC_SEQ_CST);
    if (now != value) {
      __atomic_store_n(sleeping, 0u, __ATOMIC_RELAXED);
      return now;
    }
    futex_wait(word, value);
    __atomic_store_n(sleeping, 0u, __ATOMIC_RELAXED);
    const uint32_t after = __atomic_load_n(word, __ATOMIC_ACQUIRE);
    if (after != value) {
      return after;
    }
  }
}

static void publish(uint32_t *word, uint32_t value, const uint32_t *sleeping) {
  __atomic_store_n(word, value, __ATOMIC_SEQ_CST);
  if (__atomic_load_n(sleeping, __ATOMIC_SEQ_CST)) {
    futex_wake(word);
  }
}

static void *worker_main(void *arg) {
  world_t *world = arg;
  uint32_t seen = 0;
  for (;;) {
    seen = await_change(&world->work_gen, seen, &world->worker_sleeping, &world->worker_park);
    if (world->worker_stop) {
      publish(&world->done_gen, seen, &world->main_sleeping);
      return NULL;
    }
    const sim_cycles_t until = world->work_until;
    for (size_t i = world->split; i < world->servo_count; i++) {
      servo_run_until(world->servos[i], until);
    }
    publish(&world->done_gen, seen, &world->main_sleeping);
  }
}

unsigned world_set_threads(world_t *world, unsigned threads) {
  world->threads_chosen = true;
  if (threads >= 2 && !world->worker_started) {
    world->worker_stop = false;
    world->work_gen = world->done_gen = 0;
    sigset_t all, old; /* signals go to the caller's thread */
    sigfillset(&all);
    pthread_sigmask(SIG_SETMASK, &all, &old);
    if (pthread_create(&world->worker, NULL, worker_main, world) == 0) {
      world->worker_started = true;
    }
    pthread_sigmask(SIG_SETMASK, &old, NULL);
  } else if (threads < 2 && world->worker_started) {
    world->worker_stop = true;
    const uint32_t gen = world->work_gen + 1u;
    publish(&world->work_gen, gen, &world->worker_sleeping);
    pthread_join(world->worker, NULL);
    world->worker_started = false;
  }
  return world->worker_started ? 2u : 1u;
}

void world_run_servos(world_t *world, sim_cycles_t horizon) {
  if (!world->worker_started || world->servo_count < 2) {
    for (size_t i = 0; i < world->servo_count; i++) {
      servo_run_until(world->servos[i], horizon);
    }
    return;
  }
  world->split = world->servo_count / 2u;
  world->work_until = horizon;
  const uint32_t gen = world->work_gen + 1u;
  publish(&world->work_gen, gen, &world->worker_sleeping);
  for (size_t i = 0; i < world->split; i++) {
    servo_run_until(world->servos[i], horizon);
  }
  uint32_t done = __atomic_load_n(&world->done_gen, __ATOMIC_ACQUIRE);
  while (done != gen) {
    done = await_change(&world->done_gen, done, &world->main_sleeping, NULL);
  }
}

void world_choose_threads(world_t *world) {
  const char *env = getenv("AX12_SIM_THREADS");
  unsigned threads = 1u;
  if (env && *env) {
    threads = (unsigned)atoi(env);
  }
  (void)world_set_threads(world, threads);
}

void world_park(world_t *world) { __atomic_store_n(&world->worker_park, true, __ATOMIC_RELAXED); }
