/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The inline part of the simavr_patch module (simavr_patch.h): the core's run loop and the
 * cycle-timer look-ups on the emulator's innermost path (servo_run.c, servo_profile.c). */
#ifndef SIM_SIMAVR_PATCH_RUN_H
#define SIM_SIMAVR_PATCH_RUN_H

#include <sim_avr.h>
#include <sim_core.h>
#include <sim_cycle_timers.h>
#include <sim_interrupts.h>

#include "fast_core.h"
#include "simavr_patch.h"
#include "sim_time.h"

/* avr_service_interrupts() of simavr 1.6 with the fast core's entry (fast_core.h): I set and
 * an interrupt pending or the instructions after SEI/RETI being counted down. */
static inline void simavr_service_interrupts_fast(avr_t *avr) {
  if (!avr->sreg[S_I] || !avr->interrupt_state) {
    return;
  }
  if (avr->interrupt_state < 0) { /* the instruction after SEI or RETI runs first */
    avr->interrupt_state++;
    if (avr->interrupt_state == 0) {
      avr->interrupt_state = avr->interrupts.pending.read != avr->interrupts.pending.write;
    }
    return;
  }
  fast_core_enter_interrupt(avr);
}

/* When the first cycle timer is due (absolute cycles), SIM_CYCLES_NEVER when none is. */
static inline sim_cycles_t simavr_first_timer_when(const avr_t *avr) {
  const avr_cycle_timer_slot_p first = avr->cycle_timers.timer;
  return first ? first->when : SIM_CYCLES_NEVER;
}

/* When the first cycle timer is due whose owner (the param it was registered with) passed_over()
 * does not reject; SIM_CYCLES_NEVER when none. Inline: servo_earliest_wake asks it for every
 * sleeping servo at every step of the world, and passed_over() inlines into it. */
static inline __attribute__((always_inline)) sim_cycles_t
simavr_first_timer_when_except(const avr_t *avr, bool (*passed_over)(const void *owner, const void *ctx), const void *ctx) {
  for (avr_cycle_timer_slot_p slot = avr->cycle_timers.timer; slot; slot = slot->next) {
    if (!passed_over(slot->param, ctx)) {
      return slot->when;
    }
  }
  return SIM_CYCLES_NEVER;
}

/* Sets the core's clock (absolute cycles): where a servo that joins a running world starts,
 * and how a sleeping core's clock jumps (servo_run.c). */
static inline void simavr_set_clock(avr_t *avr, sim_cycles_t cycles) { avr->cycle = cycles; }

/* Makes a batch (simavr_step_core) end after an instruction that registers or cancels a cycle
 * timer: simavr re-clamps run_cycle_count to at most run_cycle_limit then. 1 is simavr's own
 * value after avr_init() and every reset; set again before each run, so nothing depends on
 * that. */
static inline void simavr_end_batches_at_timer_changes(avr_t *avr) { avr->run_cycle_limit = 1; }

/* simavr 1.6: one step of the core, as its avr_callback_run_raw() without its sleep: run
 * instructions (if awake), the due cycle timers, and the interrupts. simavr would jump a
 * sleeping core's clock one cycle past its next timer, and on from there to the following
 * timer within the same call; servo_run.c advances a sleeping clock itself, exactly.
 *
 * A running core executes a batch: avr_run_one() goes on from instruction to instruction while
 * avr->run_cycle_count cycles are left, the core runs and no interrupt is pending. The count
 * is set to reach the first cycle timer or `until`, whichever comes first. An instruction that
 * registers or cancels a cycle timer (a UDR0 read, an ADC start, WDR...) makes simavr re-clamp
 * the count to min(run_cycle_limit, first timer - now); with run_cycle_limit at 1 (simavr's
 * own value after avr_init and every reset, and what simavr_end_batches_at_timer_changes()
 * sets) the batch then ends after that instruction, and the next step bounds a new one. So a
 * batch ends at the first instruction boundary at or after the first cycle timer or `until`,
 * where an instruction-by-instruction loop would have stopped: the same cycles, fewer calls.
 * until = 0 runs one instruction. The batch runs in the fast core (fast_core.h) when the servo
 * has one and no gdb is attached, else in simavr's avr_run_one(): the same instructions. */
static inline __attribute__((always_inline)) void simavr_step_core(avr_t *avr, fast_core_t *core, sim_cycles_t until) {
  avr_flashaddr_t new_pc = avr->pc;
  if (avr->state == cpu_Running) {
    const avr_cycle_timer_slot_p first = avr->cycle_timers.timer;
    const sim_cycles_t end = first && first->when < until ? first->when : until;
    avr->run_cycle_count = end > avr->cycle ? end - avr->cycle : 1u;
    new_pc = core && !avr->gdb ? fast_core_run(core, avr, until) : avr_run_one(avr);
  }
  const avr_cycle_timer_slot_p due = avr->cycle_timers.timer;
  if (due && due->when <= avr->cycle) { /* what avr_cycle_timer_process() checks first */
    (void)avr_cycle_timer_process(avr);
  }
  avr->pc = new_pc;
  if (avr->state == cpu_Sleeping && !avr->sreg[S_I]) {
    avr->state = cpu_Done; /* SLEEP with interrupts off: nothing can wake it */
    return;
  }
  if ((avr->state == cpu_Running || avr->state == cpu_Sleeping) && avr->interrupt_state) {
    if (core) {
      simavr_service_interrupts_fast(avr);
    } else {
      avr_service_interrupts(avr);
    }
  }
}

/* simavr_reset_requested (simavr_patch.h), inline for the run loop. */
void simavr_run_one_step(avr_t *avr);
static inline bool simavr_reset_requested_inline(const avr_t *avr) { return avr->run != simavr_run_one_step; }

#endif
