/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "servo_profile.h"

#include <sim_avr.h>

#include "simavr_patch_run.h"

__attribute__((noinline)) void servo_profiled_step(servo_t *servo) {
  avr_t *avr = servo->avr;
  const avr_flashaddr_t pc_before = avr->pc;
  const sim_cycles_t cycle_before = avr->cycle;
  simavr_step_core(avr, servo->fast_core, 0);
  servo->pc_cycles[(pc_before / 2u) % servo->pc_cycles_words] += avr->cycle - cycle_before;
}

/* From the instruction at probe_pc (an ISR's entry) until the core sleeps again. An entry
 * while already inside (the work overran into the next period) extends it. */
void servo_probe_step(servo_t *servo) {
  avr_t *avr = servo->avr;
  if (!servo->probe_inside) {
    if (avr->pc == servo->probe_pc) {
      servo->probe_start = avr->cycle;
      servo->probe_inside = true;
    }
    return;
  }
  if (avr->state == cpu_Sleeping) {
    const sim_cycles_t spent = avr->cycle - servo->probe_start;
    servo->probe_inside = false;
    servo->probe_calls++;
    servo->probe_total_cycles += spent;
    if (spent > servo->probe_max_cycles) {
      servo->probe_max_cycles = spent;
    }
  }
}

void servo_set_probe(servo_t *servo, uint32_t entry_pc) {
  servo->probe_pc = entry_pc;
  servo->probe_inside = false;
  servo->probe_calls = 0;
  servo->probe_max_cycles = servo->probe_total_cycles = 0;
}
