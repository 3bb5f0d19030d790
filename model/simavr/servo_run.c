/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "servo_run.h"

#include <stdio.h>

#include <sim_avr.h>

#include "quiet_timer.h"
#include "servo_profile.h"
#include "simavr_patch.h"
#include "simavr_patch_run.h"

/* An event of a timer module whose interrupts are all off cannot wake the core. */
static inline bool event_cannot_wake(const void *owner, const void *ctx) {
  const servo_t *servo = ctx;
  for (unsigned i = 0; i < servo->timer_count; i++) {
    if (owner == servo->timers[i]) {
      return !timer_enables_any(servo->avr->data, &servo->timer_enables[i]);
    }
  }
  return false;
}

sim_cycles_t servo_earliest_wake(const servo_t *servo, sim_cycles_t now) {
  const avr_t *avr = servo->avr;
  if (servo->halted) {
    return SIM_CYCLES_NEVER;
  }
  if (avr->state != cpu_Sleeping || avr->interrupt_state) {
    return now;
  }
  /* A timer module's quietness is looked up only when one of its events comes first (usually
   * the first is the control tick's, or a byte's). */
  const sim_cycles_t when = simavr_first_timer_when_except(avr, event_cannot_wake, servo);
  if (when == SIM_CYCLES_NEVER) {
    return SIM_CYCLES_NEVER;
  }
  return when > now ? when : now;
}

/* The core runs, or a cycle timer is due before t. */
static __attribute__((noinline)) void run_awake(servo_t *servo, sim_cycles_t t) {
  avr_t *avr = servo->avr;
  simavr_end_batches_at_timer_changes(avr);
  const sim_cycles_t until = servo->single_step || servo->probe_pc ? 0 : t; /* the profile: 0 too */
  while (!servo->halted && avr->cycle < t) {
    /* simavr 1.6's own sleep would land one cycle past the next timer and could jump past t:
     * the clock is moved here, exactly to the next timer (or t). */
    if (avr->state == cpu_Sleeping) {
      const sim_cycles_t next = simavr_first_timer_when(avr);
      if (next >= t) {
        servo->sleep_cycles += t - avr->cycle;
        simavr_set_clock(avr, t);
        break;
      }
      if (next > avr->cycle) {
        servo->sleep_cycles += next - avr->cycle;
        simavr_set_clock(avr, next);
      }
    }
    if (__builtin_expect(servo->pc_cycles != NULL, 0)) {
      servo_profiled_step(servo);
    } else {
      simavr_step_core(avr, servo->fast_core, until);
    }
    if (servo->probe_pc) {
      servo_probe_step(servo);
    }
    if (__builtin_expect(simavr_reset_requested_inline(avr), 0)) {
      servo_reset(servo); /* the watchdog expired (simavr_patch.h) */
      servo->watchdog_resets++;
      simavr_end_batches_at_timer_changes(avr);
    }
    if (avr->state == cpu_Done || avr->state == cpu_Crashed) {
      servo->halted = true;
      servo->halt_state = avr->state;
      fprintf(stderr, "%s: the MCU stopped (%s) at cycle %llu, pc 0x%04x\n", servo->name,
              avr->state == cpu_Done ? "sleep with interrupts off" : "crash", (unsigned long long)avr->cycle,
              (unsigned)avr->pc);
    }
  }
}

void servo_run_until(servo_t *servo, sim_cycles_t t) {
  avr_t *avr = servo->avr;
  if (servo->halted || avr->cycle >= t) {
    return;
  }
  if (avr->state == cpu_Sleeping && !avr->interrupt_state && simavr_first_timer_when(avr) >= t) {
    servo->sleep_cycles += t - avr->cycle; /* nothing wakes it before t: the usual case */
    simavr_set_clock(avr, t);
    return;
  }
  run_awake(servo, t);
}
