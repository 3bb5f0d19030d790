/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Running a servo's core to a given simulated time: batches of instructions between cycle
 * timers, a sleeping core's clock moved from timer to timer, and when the core can next act. */
#ifndef SIM_SERVO_RUN_H
#define SIM_SERVO_RUN_H

#include "servo.h"
#include "sim_time.h"

/* Runs the MCU until its clock reaches t: a running core stops at the first instruction
 * boundary at or after t, a sleeping one exactly at t. A sleeping core's clock jumps from
 * one cycle timer to the next (idle firmware costs almost nothing); a running one executes
 * the instructions up to the next cycle timer (or t) in one call into simavr, which stops
 * at the same boundaries as one instruction at a time would (single_step). With a probe or a
 * cycle profile set (servo_profile.h) it runs one instruction a step. */
void servo_run_until(servo_t *servo, sim_cycles_t t);

/* The earliest simulated time at which this MCU may execute an instruction (and so start a
 * byte on the wire), as far as can be told at `now` without running it: `now` for a running
 * core or one with an interrupt pending; for a sleeping core the time of its first cycle
 * timer that can raise an interrupt (timer events of a timer module whose interrupts are all
 * disabled do not wake it: Timer0's PWM overflows); SIM_CYCLES_NEVER for a halted one. */
sim_cycles_t servo_earliest_wake(const servo_t *servo, sim_cycles_t now);

#endif
