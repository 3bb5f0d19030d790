/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "quiet_timer.h"

#include <string.h>

#include <avr_timer.h>
#include <sim_avr.h>
#include <sim_io.h>

bool quiet_timer_interrupts_off(struct avr_t *avr, const struct avr_timer_t *timer) {
  if (avr_regbit_get(avr, timer->overflow.enable) || avr_regbit_get(avr, timer->icr.enable)) {
    return false;
  }
  for (int i = 0; i < AVR_TIMER_COMP_COUNT; i++) {
    if (avr_regbit_get(avr, timer->comp[i].interrupt.enable)) {
      return false;
    }
  }
  return true;
}

static void add_enable(timer_enables_t *out, avr_regbit_t rb) {
  if (!rb.reg) {
    return; /* avr_regbit_get reads 0 */
  }
  const unsigned char mask = (unsigned char)(rb.mask << rb.bit);
  for (unsigned i = 0; i < out->count; i++) {
    if (out->reg[i] == rb.reg) {
      out->mask[i] |= mask;
      return;
    }
  }
  out->reg[out->count] = rb.reg;
  out->mask[out->count] = mask;
  out->count++;
}

void timer_enables_of(const struct avr_timer_t *timer, timer_enables_t *out) {
  memset(out, 0, sizeof(*out));
  add_enable(out, timer->overflow.enable);
  add_enable(out, timer->icr.enable);
  for (int i = 0; i < AVR_TIMER_COMP_COUNT; i++) {
    add_enable(out, timer->comp[i].interrupt.enable);
  }
}

static void cancel_events(quiet_timer_t *qt) { qt->cancelled += simavr_cancel_timers_of(qt->avr, qt->timer); }

/* simavr 1.6 schedules the timer's events from its control registers: a stop and a start
 * (TCCRnB = 0, then its value) make it schedule them afresh from now. */
static void restart(quiet_timer_t *qt) {
  const avr_io_addr_t tccrb = qt->timer->cs[0].reg;
  for (unsigned i = 0; i < qt->count; i++) {
    if (qt->addr[i] == tccrb) {
      const uint8_t value = qt->avr->data[tccrb];
      io_hook_chain(&qt->replaced[i], qt->avr, tccrb, 0);
      io_hook_chain(&qt->replaced[i], qt->avr, tccrb, value);
    }
  }
}

static void settle(quiet_timer_t *qt) {
  if (!qt->enabled || !qt->quiet) {
    return;
  }
  if (!quiet_timer_interrupts_off(qt->avr, qt->timer)) {
    qt->quiet = false;
    restart(qt);
    return;
  }
  cancel_events(qt);
}

static void on_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param) {
  quiet_timer_t *qt = param;
  for (unsigned i = 0; i < qt->count; i++) {
    if (qt->addr[i] == addr) {
      io_hook_chain(&qt->replaced[i], avr, addr, v);
      break;
    }
  }
  settle(qt);
}

static void hook(quiet_timer_t *qt, avr_io_addr_t addr) {
  if (addr == 0 || qt->count == QUIET_TIMER_REGS) {
    return;
  }
  for (unsigned i = 0; i < qt->count; i++) {
    if (qt->addr[i] == addr) {
      return;
    }
  }
  const unsigned i = qt->count++;
  qt->addr[i] = addr;
  io_hook_write(qt->avr, addr, on_write, qt, &qt->replaced[i]);
}

bool quiet_timer_attach(quiet_timer_t *qt, struct avr_t *avr, struct avr_timer_t *timer) {
  memset(qt, 0, sizeof(*qt));
  qt->avr = avr;
  qt->timer = timer;
  qt->enabled = true;
  qt->quiet = true;
  if (!timer->cs[0].reg || !timer->wgm[0].reg || !timer->r_tcnt || !timer->overflow.enable.reg) {
    return false;
  }
  hook(qt, timer->wgm[0].reg);  /* TCCRnA */
  hook(qt, timer->cs[0].reg);   /* TCCRnB */
  hook(qt, timer->r_tcnt);      /* TCNTn */
  hook(qt, timer->comp[AVR_TIMER_COMPA].r_ocr);
  hook(qt, timer->comp[AVR_TIMER_COMPB].r_ocr);
  hook(qt, timer->overflow.enable.reg); /* TIMSKn */
  settle(qt);
  return true;
}

void quiet_timer_enable(quiet_timer_t *qt, bool enabled) {
  const bool was = qt->enabled && qt->quiet;
  qt->enabled = enabled;
  if (was && !enabled) {
    restart(qt);
  }
  settle(qt);
}
