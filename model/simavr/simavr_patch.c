/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "simavr_patch_run.h"

#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include <avr_extint.h>
#include <avr_uart.h>
#include <sim_io.h>

/* ---- I/O register handlers ---- */

#define IO_SLOT(avr, addr) ((avr)->io[AVR_DATA_TO_IO(addr)])

void io_hook_write(struct avr_t *avr, uint16_t addr, io_write_fn fn, void *param, io_write_hook_t *replaced) {
  replaced->c = (io_write_fn)IO_SLOT(avr, addr).w.c;
  replaced->param = IO_SLOT(avr, addr).w.param;
  io_take_write(avr, addr, fn, param);
}

void io_hook_chain(const io_write_hook_t *replaced, struct avr_t *avr, uint16_t addr, uint8_t v) {
  if (replaced->c) {
    replaced->c(avr, addr, v, replaced->param);
  } else {
    avr->data[addr] = v;
  }
}

void io_take_read(struct avr_t *avr, uint16_t addr, io_read_fn fn, void *param) {
  IO_SLOT(avr, addr).r.c = (avr_io_read_t)fn;
  IO_SLOT(avr, addr).r.param = param;
}

void io_take_write(struct avr_t *avr, uint16_t addr, io_write_fn fn, void *param) {
  IO_SLOT(avr, addr).w.c = (avr_io_write_t)fn;
  IO_SLOT(avr, addr).w.param = param;
}

bool io_has_read(const struct avr_t *avr, uint16_t addr) { return IO_SLOT(avr, addr).r.c != NULL; }

/* ---- the cycle-timer list ---- */

sim_cycles_t simavr_first_timer_when_except(const avr_t *avr, bool (*skip)(const void *owner, const void *ctx),
                                            const void *ctx) {
  for (avr_cycle_timer_slot_p slot = avr->cycle_timers.timer; slot; slot = slot->next) {
    if (!skip(slot->param, ctx)) {
      return slot->when;
    }
  }
  return SIM_CYCLES_NEVER;
}

unsigned simavr_cancel_timers_of(avr_t *avr, const void *owner) {
  unsigned cancelled = 0;
  for (;;) {
    avr_cycle_timer_slot_p slot = avr->cycle_timers.timer;
    while (slot && slot->param != owner) {
      slot = slot->next;
    }
    if (!slot) {
      return cancelled;
    }
    avr_cycle_timer_cancel(avr, slot->timer, slot->param);
    cancelled++;
  }
}

/* ---- the run loop ---- */

static void sleep_nothing(avr_t *avr, avr_cycle_count_t how_long) {
  (void)avr;
  (void)how_long;
}

static void run_one_step(avr_t *avr) { simavr_step_core(avr, 0); }

void simavr_install_run_loop(avr_t *avr) {
  avr->sleep = sleep_nothing;
  avr->run = run_one_step;
}

bool simavr_reset_requested(const avr_t *avr) { return avr->run != run_one_step; }

/* ---- the external-interrupt module ---- */

/* The context of simavr 1.6's level poll timer (avr_extint.c, private there; freed by the
 * poll itself when it ends). */
typedef struct {
  uint32_t eint_no;
  avr_extint_t *extint;
} extint_poll_context_t;

void simavr_extint_poll_off(avr_t *avr) {
  avr_extint_t *extint = NULL;
  for (avr_io_t *io = avr->io_port; io; io = io->next) {
    if (io->kind && strcmp(io->kind, "extint") == 0) {
      extint = (avr_extint_t *)io;
    }
  }
  if (!extint) {
    return;
  }
  for (uint8_t i = 0; i < 2; i++) {
    avr_extint_set_strict_lvl_trig(avr, i, 0);
  }
  bool cancelled;
  do {
    cancelled = false;
    for (avr_cycle_timer_slot_p t = avr->cycle_timers.timer; t; t = t->next) {
      const extint_poll_context_t *ctx = t->param;
      if (ctx && ctx->extint == extint && ctx->eint_no < EXTINT_COUNT) {
        void *param = t->param;
        avr_cycle_timer_cancel(avr, t->timer, param);
        free(param);
        cancelled = true;
        break;
      }
    }
  } while (cancelled);
}

/* ---- the USART ---- */

void simavr_uart_rx_limiter_reset(struct avr_uart_t *uart) {
  uart->rx_cnt = 0;
  uart->rxc_raise_time = 0;
}
