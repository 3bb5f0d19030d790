/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Measuring the firmware on a servo: the busy-time probe (cycles from an ISR's entry until the
 * core sleeps again) and the cycle profile by instruction address (servo_t.pc_cycles). Both
 * make servo_run_until() run one instruction a step. */
#ifndef SIM_SERVO_PROFILE_H
#define SIM_SERVO_PROFILE_H

#include <stdint.h>

#include "servo.h"

/* Measures the busy time after each execution of the instruction at byte address entry_pc
 * (0 = off), typically an ISR's entry: cycles from there until the core next sleeps (the work
 * the interrupt wakes the main loop for, other interrupts meanwhile included). Count, worst
 * and total in probe_calls, probe_max_cycles, probe_total_cycles. */
void servo_set_probe(servo_t *servo, uint32_t entry_pc);

/* For servo_run.c: after each step while a probe is set. */
void servo_probe_step(servo_t *servo);

/* For servo_run.c: one instruction (or an interrupt's entry), its cycles added to
 * servo->pc_cycles at the word address it started at. */
void servo_profiled_step(servo_t *servo);

#endif
