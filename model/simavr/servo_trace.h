/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The probes of one servo's waveform trace (world_trace.h writes them to a VCD): its pins and
 * its control tick as value changes stamped with the simulated cycle, collected in a buffer
 * that the world's trace drains in time order.
 *
 * Signals (SERVO_TRACE_*):
 *   rx      the transceiver's receive side: each byte the bus hands this servo, bit by bit at
 *           the sender's bit time (start bit 0, 8 data bits LSB first as this servo decodes
 *           them, stop bit 1); idle 1. Shown whether or not the USART takes it (PD2, RXEN).
 *   tx      TXD: each byte the USART shifts out, bit by bit at its own bit time; idle 1.
 *   dir     PD2, the direction pin (1 = the servo drives the bus).
 *   led     PB5.
 *   pwm_a, pwm_b   the H-bridge inputs OC0A (PD6) and OC0B (PD5): Timer0's waveform as the
 *           datasheet gives it for the firmware's mode (fast PWM, TOP 0xFF: the output set at
 *           BOTTOM, cleared after the match, OCR0x taken at BOTTOM), synthesized here from the
 *           register writes and the cycle counter, since the emulator does not simulate
 *           Timer0's events (quiet_timer.h); the port bit while COM0x disconnects the pin.
 *           In any other Timer0 mode both show their port bits.
 *   ocr0a, ocr0b   the duty registers (8 bits) as written.
 *   tick    1 while the control tick's interrupt (Timer1 COMPB, every 1 ms) runs, from its
 *           vector to its RETI (simavr's interrupt "running" IRQ).
 *
 * An MCU reset (the watchdog) is followed: Timer0 stopped, the USART's byte in flight cut
 * (tx idle from then), the tick's interrupt ended.
 *
 * Event times come from the servo's clock and are exact. tx and the PWM edges are known
 * ahead of time, rx once the bus finalizes a byte (at its end): the buffer is not in time
 * order, world_trace sorts what it drains. Every probe writes only this servo's buffer, so
 * servos may run on two threads (world_set_threads). */
#ifndef SIM_SERVO_TRACE_H
#define SIM_SERVO_TRACE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "servo.h"
#include "sim_time.h"
#include "uart_link.h"

enum {
  SERVO_TRACE_RX,
  SERVO_TRACE_TX,
  SERVO_TRACE_DIR,
  SERVO_TRACE_LED,
  SERVO_TRACE_PWM_A,
  SERVO_TRACE_PWM_B,
  SERVO_TRACE_OCR0A,
  SERVO_TRACE_OCR0B,
  SERVO_TRACE_TICK,
  SERVO_TRACE_SIGNALS
};

typedef struct {
  const char *name;
  unsigned width;  /* bits */
  uint32_t initial;
} servo_trace_signal_t;

/* Name, width and value at power-up of each signal, indexed by SERVO_TRACE_*. */
extern const servo_trace_signal_t servo_trace_signals[SERVO_TRACE_SIGNALS];

typedef struct {
  sim_cycles_t at;
  uint32_t seq;    /* order of recording within the servo (same `at`: the later wins) */
  uint16_t signal; /* SERVO_TRACE_* */
  uint32_t value;
} servo_trace_event_t;

/* Timer0's waveform generator as far as the trace models it (fast PWM, TOP 0xFF). */
typedef struct {
  uint8_t tccr0a, tccr0b;
  uint8_t count;            /* TCNT0 while stopped */
  unsigned prescale;        /* timer clock in MCU cycles; 0 = stopped or not modelled */
  sim_cycles_t next_bottom; /* running: when the count next wraps to 0 */
  sim_cycles_t match_at[2]; /* running: this period's compare match of A / B, or NEVER */
  uint8_t ocr_buffer[2];    /* OCR0A / OCR0B as written */
  uint8_t ocr_active[2];    /* as the comparator uses them (taken at BOTTOM) */
  bool oc[2];               /* the OC0A / OC0B output registers */
  sim_cycles_t done_until;  /* edges recorded up to this cycle */
} servo_trace_pwm_t;

typedef struct servo_trace {
  servo_t *servo;
  uart_link_observer_t observer;
  servo_trace_event_t *events;
  size_t count, cap;
  uint32_t seq;
  bool out_of_memory; /* an event was lost */
  uint32_t last[SERVO_TRACE_SIGNALS]; /* the last value recorded, per signal */
  uint8_t port_d, ddr_d, port_b, ddr_b;
  servo_trace_pwm_t pwm;
  io_write_hook_t timer_replaced[5]; /* TCCR0A, TCCR0B, TCNT0, OCR0A, OCR0B */
  uint16_t timer_addr[5];
  struct avr_irq_t *irqs[5]; /* the IRQs notified (PORTD, DDRD, PORTB, DDRB, the tick) */
  void (*chained_on_reset)(void *ctx); /* the board's reset callback this one wraps */
  void *chained_on_reset_ctx;
} servo_trace_t;

/* Starts probing servo (call once, before it runs under trace; it stays probed until
 * servo_trace_detach). False with err set when the MCU lacks a part. */
bool servo_trace_attach(servo_trace_t *trace, servo_t *servo, char *err, size_t err_len);

/* Stops probing and frees the buffer (before the servo is destroyed). */
void servo_trace_detach(servo_trace_t *trace);

/* Records the PWM edges up to cycle t (t not before an earlier call's); world_trace calls it
 * before draining. */
void servo_trace_advance(servo_trace_t *trace, sim_cycles_t t);

#endif
