/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Timer events nobody can see, not simulated (a simavr 1.6 workaround, for speed).
 *
 * simavr 1.6 runs an 8-bit timer in PWM mode as three cycle timers per period (overflow,
 * compare A, compare B): at clk/1 one every 85 cycles, with or without an interrupt enabled.
 * They set flags in TIFR0 and levels on the OC0A / OC0B pins, and that is all they do; the
 * duty reaches the board through the OCR writes (TIMER_IRQ_OUT_PWM0/1), which still happen.
 * While a driven AX-12 holds or moves, they were about a sixth of the emulator's work.
 *
 * A quiet timer is one with none of its interrupts enabled. For one that stays quiet, this
 * module cancels those cycle timers whenever simavr (re)schedules them, that is after each
 * write to the timer's control, compare or count registers. What is then no longer simulated:
 * its count (TCNT0 reads as of the last write), its flags in TIFR0 and its compare pins'
 * levels (PIND bits). The firmware reads none of these (docs/emulator.md; the test
 * `test_quiet_timer0_changes_nothing_the_firmware_does` runs a script both ways and compares
 * wire, RAM and plant). A write that enables one of its interrupts ends the quiet mode for
 * good: simavr's schedule is restarted from that moment (the prescaler and the count restart,
 * a difference no firmware here can meet). */
#ifndef SIM_QUIET_TIMER_H
#define SIM_QUIET_TIMER_H

#include <stdbool.h>

#include "simavr_patch.h"

struct avr_t;
struct avr_timer_t;

#define QUIET_TIMER_REGS 6u

typedef struct {
  struct avr_t *avr;
  struct avr_timer_t *timer;
  bool enabled; /* false: every event is simulated (the reference a test compares with) */
  bool quiet;   /* no interrupt of the timer has been enabled since power-up */
  unsigned count;
  unsigned short addr[QUIET_TIMER_REGS];
  io_write_hook_t replaced[QUIET_TIMER_REGS];
  unsigned long long cancelled; /* cycle timers cancelled (statistics) */
} quiet_timer_t;

/* True when none of the timer's interrupts is enabled. */
bool quiet_timer_interrupts_off(struct avr_t *avr, const struct avr_timer_t *timer);

/* A timer's interrupt enable bits (overflow, input capture, compares) merged by register: the
 * same answer as quiet_timer_interrupts_off() from one or two byte tests (servo_run.c asks it
 * for every sleeping servo at every step of the world). */
#define TIMER_ENABLE_REGS 5u
typedef struct {
  unsigned short reg[TIMER_ENABLE_REGS];
  unsigned char mask[TIMER_ENABLE_REGS];
  unsigned count;
} timer_enables_t;

void timer_enables_of(const struct avr_timer_t *timer, timer_enables_t *out);

/* True when one of the bits is set in data (simavr's data space, avr->data). */
static inline bool timer_enables_any(const unsigned char *data, const timer_enables_t *e) {
  for (unsigned i = 0; i < e->count; i++) {
    if (data[e->reg[i]] & e->mask[i]) {
      return true;
    }
  }
  return false;
}

/* Hooks the register writes of `timer` (a simavr avr_timer_t of `avr`). Returns false if its
 * registers are not where this expects them. */
bool quiet_timer_attach(quiet_timer_t *qt, struct avr_t *avr, struct avr_timer_t *timer);

/* Turns quieting on (the default after attach) or off; off re-schedules every event. */
void quiet_timer_enable(quiet_timer_t *qt, bool enabled);

#endif
