/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "servo_trace.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <avr_ioport.h>
#include <avr_timer.h>
#include <sim_avr.h>
#include <sim_interrupts.h>
#include <sim_io.h>
#include <sim_irq.h>

#include "simavr_patch.h"

const servo_trace_signal_t servo_trace_signals[SERVO_TRACE_SIGNALS] = {
    [SERVO_TRACE_RX] = {"rx", 1, 1},       [SERVO_TRACE_TX] = {"tx", 1, 1},
    [SERVO_TRACE_DIR] = {"dir", 1, 0},     [SERVO_TRACE_LED] = {"led", 1, 0},
    [SERVO_TRACE_PWM_A] = {"pwm_a", 1, 0}, [SERVO_TRACE_PWM_B] = {"pwm_b", 1, 0},
    [SERVO_TRACE_OCR0A] = {"ocr0a", 8, 0}, [SERVO_TRACE_OCR0B] = {"ocr0b", 8, 0},
    [SERVO_TRACE_TICK] = {"tick", 1, 0},
};

/* Pins (docs/hardware.md). */
#define PIN_DIRECTION 2 /* PD2 */
#define PIN_LED 5       /* PB5 */
#define PIN_OC0A 6      /* PD6 */
#define PIN_OC0B 5      /* PD5 */

/* Timer0 of the ATmega88 / ATmega328P (datasheet, "8-bit Timer/Counter0 with PWM"). */
#define TIMER0_TOP 256u               /* counts per period (TOP 0xFF) */
#define TCCR0A_WGM_MASK 0x03u         /* WGM01:0 */
#define TCCR0B_WGM02 0x08u
#define TCCR0B_CS_MASK 0x07u
#define WGM_FAST_PWM_TOP_FF 0x03u
#define COM0A_SHIFT 6
#define COM0B_SHIFT 4
#define COM_INVERTING 3u              /* set at match, clear at BOTTOM */
#define COM_NON_INVERTING 2u          /* clear at match, set at BOTTOM */

enum { REG_TCCR0A, REG_TCCR0B, REG_TCNT0, REG_OCR0A, REG_OCR0B, TIMER_REGS };
enum { IRQ_PORT_D, IRQ_DDR_D, IRQ_PORT_B, IRQ_DDR_B, IRQ_TICK, TRACE_IRQS };

static void record(servo_trace_t *tr, sim_cycles_t at, unsigned signal, uint32_t value) {
  if (tr->count == tr->cap) {
    const size_t cap = tr->cap ? 2u * tr->cap : 1024u;
    servo_trace_event_t *grown = realloc(tr->events, cap * sizeof(*grown));
    if (!grown) {
      tr->out_of_memory = true;
      return;
    }
    tr->events = grown;
    tr->cap = cap;
  }
  tr->events[tr->count++] = (servo_trace_event_t){.at = at, .seq = tr->seq++, .signal = (uint16_t)signal, .value = value};
  tr->last[signal] = value;
}

/* For the signals recorded in time order: only changes. */
static void record_level(servo_trace_t *tr, sim_cycles_t at, unsigned signal, uint32_t value) {
  if (tr->last[signal] != value) {
    record(tr, at, signal, value);
  }
}

/* ---- the USART's pins ---- */

/* A frame, 8N1: start bit 0, data LSB first, stop bit 1, each at start + k x bit time. */
static void record_frame(servo_trace_t *tr, unsigned signal, uint8_t value, sim_cycles_t start, double bit) {
  record(tr, start, signal, 0);
  for (unsigned k = 1; k <= 8; k++) {
    record(tr, start + (sim_cycles_t)(k * bit + 0.5), signal, (value >> (k - 1u)) & 1u);
  }
  record(tr, start + (sim_cycles_t)(9.0 * bit + 0.5), signal, 1);
}

static void on_tx(void *ctx, uint8_t value, sim_cycles_t start, double cycles_per_bit) {
  record_frame(ctx, SERVO_TRACE_TX, value, start, cycles_per_bit);
}

static void on_rx(void *ctx, const bus_rx_t *rx) {
  const double bit = (double)(rx->end - rx->start) / BUS_FRAME_BITS_8N1;
  record_frame(ctx, SERVO_TRACE_RX, rx->value, rx->start, bit);
}

/* ---- Timer0's waveform ---- */

static bool com_connected(uint8_t tccr0a, unsigned ch) {
  return ((tccr0a >> (ch == 0 ? COM0A_SHIFT : COM0B_SHIFT)) & 3u) >= COM_NON_INVERTING;
}

static bool com_inverting(uint8_t tccr0a, unsigned ch) {
  return ((tccr0a >> (ch == 0 ? COM0A_SHIFT : COM0B_SHIFT)) & 3u) == COM_INVERTING;
}

/* The H-bridge input's level: the waveform while COM0x connects it, else the port bit. */
static void record_pwm_pin(servo_trace_t *tr, sim_cycles_t at, unsigned ch) {
  const servo_trace_pwm_t *p = &tr->pwm;
  const unsigned pin = ch == 0 ? PIN_OC0A : PIN_OC0B;
  const bool level = com_connected(p->tccr0a, ch) ? p->oc[ch] : ((tr->port_d & tr->ddr_d) >> pin) & 1u;
  record_level(tr, at, ch == 0 ? SERVO_TRACE_PWM_A : SERVO_TRACE_PWM_B, level);
}

/* The match of channel ch in the period that ends at next_bottom, if after `after`. */
static sim_cycles_t match_in_period(const servo_trace_pwm_t *p, unsigned ch, sim_cycles_t after) {
  if (p->ocr_active[ch] == 0xFFu) {
    return SIM_CYCLES_NEVER; /* OCR0x = TOP: a constant level, no edge */
  }
  const sim_cycles_t at = p->next_bottom - (sim_cycles_t)TIMER0_TOP * p->prescale +
                          (sim_cycles_t)(p->ocr_active[ch] + 1u) * p->prescale;
  return at > after ? at : SIM_CYCLES_NEVER;
}

void servo_trace_advance(servo_trace_t *tr, sim_cycles_t t) {
  servo_trace_pwm_t *p = &tr->pwm;
  if (t <= p->done_until) {
    return;
  }
  while (p->prescale) {
    for (unsigned ch = 0; ch < 2; ch++) {
      if (p->match_at[ch] <= t) {
        p->oc[ch] = com_inverting(p->tccr0a, ch);
        record_pwm_pin(tr, p->match_at[ch], ch);
        p->match_at[ch] = SIM_CYCLES_NEVER;
      }
    }
    if (p->next_bottom > t) {
      break;
    }
    const sim_cycles_t bottom = p->next_bottom;
    p->next_bottom += (sim_cycles_t)TIMER0_TOP * p->prescale;
    for (unsigned ch = 0; ch < 2; ch++) {
      p->ocr_active[ch] = p->ocr_buffer[ch];
      p->oc[ch] = !com_inverting(p->tccr0a, ch);
      record_pwm_pin(tr, bottom, ch);
      p->match_at[ch] = match_in_period(p, ch, bottom);
    }
  }
  p->done_until = t;
}

static unsigned prescale_of(uint8_t tccr0a, uint8_t tccr0b) {
  static const unsigned divisors[8] = {0, 1, 8, 64, 256, 1024, 0, 0}; /* 6, 7: pin T0, not modelled */
  const unsigned wgm = (tccr0a & TCCR0A_WGM_MASK) | ((tccr0b & TCCR0B_WGM02) ? 4u : 0u);
  return wgm == WGM_FAST_PWM_TOP_FF ? divisors[tccr0b & TCCR0B_CS_MASK] : 0u;
}

/* The count at `at` of a running timer. */
static uint8_t count_at(const servo_trace_pwm_t *p, sim_cycles_t at) {
  const sim_cycles_t left = p->next_bottom - at; /* 1..TOP x prescale */
  return (uint8_t)(TIMER0_TOP - (left + p->prescale - 1u) / p->prescale);
}

/* The timer (re)starts at `at` from p->count. */
static void start_counting(servo_trace_pwm_t *p, sim_cycles_t at) {
  p->next_bottom = at + (sim_cycles_t)(TIMER0_TOP - p->count) * p->prescale;
  for (unsigned ch = 0; ch < 2; ch++) {
    p->match_at[ch] = match_in_period(p, ch, at);
  }
}

static void timer_written(servo_trace_t *tr, unsigned reg, uint8_t v) {
  servo_trace_pwm_t *p = &tr->pwm;
  const sim_cycles_t now = tr->servo->avr->cycle;
  servo_trace_advance(tr, now);
  const unsigned was = p->prescale;
  if (was) {
    p->count = count_at(p, now);
  }
  switch (reg) {
  case REG_TCCR0A:
    p->tccr0a = v;
    break;
  case REG_TCCR0B:
    p->tccr0b = v;
    break;
  case REG_TCNT0:
    p->count = v;
    break;
  case REG_OCR0A:
  case REG_OCR0B: {
    const unsigned ch = reg == REG_OCR0A ? 0u : 1u;
    p->ocr_buffer[ch] = v;
    record_level(tr, now, ch == 0 ? SERVO_TRACE_OCR0A : SERVO_TRACE_OCR0B, v);
    break;
  }
  default:
    break;
  }
  p->prescale = prescale_of(p->tccr0a, p->tccr0b);
  if (p->prescale && (!was || reg == REG_TCNT0 || p->prescale != was)) {
    start_counting(p, now);
  }
  record_pwm_pin(tr, now, 0);
  record_pwm_pin(tr, now, 1);
}

static void timer_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param) {
  servo_trace_t *tr = param;
  for (unsigned i = 0; i < TIMER_REGS; i++) {
    if (tr->timer_addr[i] == addr) {
      io_hook_chain(&tr->timer_replaced[i], avr, addr, v);
      timer_written(tr, i, v);
      return;
    }
  }
}

/* ---- port pins and the tick ---- */

static void pins_changed(servo_trace_t *tr) {
  const sim_cycles_t now = tr->servo->avr->cycle;
  record_level(tr, now, SERVO_TRACE_DIR, ((tr->port_d & tr->ddr_d) >> PIN_DIRECTION) & 1u);
  record_level(tr, now, SERVO_TRACE_LED, ((tr->port_b & tr->ddr_b) >> PIN_LED) & 1u);
  servo_trace_advance(tr, now);
  record_pwm_pin(tr, now, 0);
  record_pwm_pin(tr, now, 1);
}

/* simavr 1.6 raises a port's PORT IRQ after storing the register, its DDR IRQ before: the
 * values come from the IRQ, the other register from memory. */
static void port_d_written(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  servo_trace_t *tr = param;
  const board_t *b = &tr->servo->board;
  tr->port_d = (uint8_t)value;
  tr->ddr_d = tr->servo->avr->data[((const avr_ioport_t *)b->port_d)->r_ddr];
  pins_changed(tr);
}

static void ddr_d_written(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  servo_trace_t *tr = param;
  tr->ddr_d = (uint8_t)value;
  tr->port_d = tr->servo->avr->data[((const avr_ioport_t *)tr->servo->board.port_d)->r_port];
  pins_changed(tr);
}

static void port_b_written(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  servo_trace_t *tr = param;
  tr->port_b = (uint8_t)value;
  tr->ddr_b = tr->servo->avr->data[((const avr_ioport_t *)tr->servo->board.port_b)->r_ddr];
  pins_changed(tr);
}

static void ddr_b_written(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  servo_trace_t *tr = param;
  tr->ddr_b = (uint8_t)value;
  tr->port_b = tr->servo->avr->data[((const avr_ioport_t *)tr->servo->board.port_b)->r_port];
  pins_changed(tr);
}

static void tick_running(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  servo_trace_t *tr = param;
  record(tr, tr->servo->avr->cycle, SERVO_TRACE_TICK, value ? 1u : 0u);
}

/* The MCU was reset (board.h on_reset, after the ports were zeroed): its registers are at
 * their reset values, which simavr set without the write hooks. */
static void mcu_reset(void *ctx) {
  servo_trace_t *tr = ctx;
  if (tr->chained_on_reset) {
    tr->chained_on_reset(tr->chained_on_reset_ctx);
  }
  const sim_cycles_t now = tr->servo->avr->cycle;
  servo_trace_advance(tr, now);
  size_t kept = 0; /* the USART's byte in flight is cut: its later bits never come */
  for (size_t e = 0; e < tr->count; e++) {
    if (!(tr->events[e].signal == SERVO_TRACE_TX && tr->events[e].at > now)) {
      tr->events[kept++] = tr->events[e];
    }
  }
  tr->count = kept;
  record(tr, now, SERVO_TRACE_TX, 1);
  record(tr, now, SERVO_TRACE_TICK, 0);
  servo_trace_pwm_t *p = &tr->pwm;
  *p = (servo_trace_pwm_t){.done_until = now, .match_at = {SIM_CYCLES_NEVER, SIM_CYCLES_NEVER}};
  record_level(tr, now, SERVO_TRACE_OCR0A, 0);
  record_level(tr, now, SERVO_TRACE_OCR0B, 0);
  tr->port_d = tr->ddr_d = tr->port_b = tr->ddr_b = 0;
  pins_changed(tr);
}

static const avr_irq_notify_t irq_handlers[TRACE_IRQS] = {
    [IRQ_PORT_D] = port_d_written, [IRQ_DDR_D] = ddr_d_written, [IRQ_PORT_B] = port_b_written,
    [IRQ_DDR_B] = ddr_b_written,   [IRQ_TICK] = tick_running,
};

static avr_timer_t *find_timer(const servo_t *servo, char name) {
  for (unsigned i = 0; i < servo->timer_count; i++) {
    avr_timer_t *t = servo->timers[i];
    if (t->name == name) {
      return t;
    }
  }
  return NULL;
}

bool servo_trace_attach(servo_trace_t *tr, servo_t *servo, char *err, size_t err_len) {
  memset(tr, 0, sizeof(*tr));
  tr->servo = servo;
  avr_t *avr = servo->avr;
  avr_timer_t *t0 = find_timer(servo, '0');
  avr_timer_t *t1 = find_timer(servo, '1');
  if (!t0 || !t1 || !servo->board.port_irq[0] || !servo->board.port_irq[3]) {
    snprintf(err, err_len, "%s: no Timer0 / Timer1 / ports B and D to trace", servo->name);
    return false;
  }
  for (unsigned s = 0; s < SERVO_TRACE_SIGNALS; s++) {
    tr->last[s] = servo_trace_signals[s].initial;
  }
  tr->pwm.done_until = avr->cycle;
  const avr_ioport_t *port_d = servo->board.port_d, *port_b = servo->board.port_b;
  tr->port_d = avr->data[port_d->r_port];
  tr->ddr_d = avr->data[port_d->r_ddr];
  tr->port_b = avr->data[port_b->r_port];
  tr->ddr_b = avr->data[port_b->r_ddr];
  for (unsigned ch = 0; ch < 2; ch++) {
    tr->pwm.match_at[ch] = SIM_CYCLES_NEVER;
  }
  tr->timer_addr[REG_TCCR0A] = t0->wgm[0].reg;
  tr->timer_addr[REG_TCCR0B] = t0->cs[0].reg;
  tr->timer_addr[REG_TCNT0] = t0->r_tcnt;
  tr->timer_addr[REG_OCR0A] = t0->comp[AVR_TIMER_COMPA].r_ocr;
  tr->timer_addr[REG_OCR0B] = t0->comp[AVR_TIMER_COMPB].r_ocr;
  for (unsigned i = 0; i < TIMER_REGS; i++) {
    io_hook_write(avr, tr->timer_addr[i], timer_write, tr, &tr->timer_replaced[i]);
  }
  /* The board's port IRQs: PORTD, DDRD, PORTB, DDRB (board.h). */
  for (unsigned i = 0; i < 4; i++) {
    tr->irqs[i] = servo->board.port_irq[i];
  }
  tr->irqs[IRQ_TICK] = t1->comp[AVR_TIMER_COMPB].interrupt.irq + AVR_INT_IRQ_RUNNING;
  for (unsigned i = 0; i < TRACE_IRQS; i++) {
    avr_irq_register_notify(tr->irqs[i], irq_handlers[i], tr);
  }
  tr->chained_on_reset = servo->board.on_reset;
  tr->chained_on_reset_ctx = servo->board.on_reset_ctx;
  servo->board.on_reset = mcu_reset;
  servo->board.on_reset_ctx = tr;
  tr->observer = (uart_link_observer_t){.tx = on_tx, .rx = on_rx, .ctx = tr};
  uart_link_observe(&servo->board.link, &tr->observer);
  return true;
}

void servo_trace_detach(servo_trace_t *tr) {
  if (!tr->servo) {
    return;
  }
  avr_t *avr = tr->servo->avr;
  uart_link_observe(&tr->servo->board.link, NULL);
  tr->servo->board.on_reset = tr->chained_on_reset;
  tr->servo->board.on_reset_ctx = tr->chained_on_reset_ctx;
  for (unsigned i = 0; i < TRACE_IRQS; i++) {
    avr_irq_unregister_notify(tr->irqs[i], irq_handlers[i], tr);
  }
  for (unsigned i = TIMER_REGS; i-- > 0;) {
    io_take_write(avr, tr->timer_addr[i], tr->timer_replaced[i].c, tr->timer_replaced[i].param);
  }
  free(tr->events);
  tr->events = NULL;
  tr->count = tr->cap = 0;
  tr->servo = NULL;
}
