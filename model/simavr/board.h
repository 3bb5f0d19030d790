/* SPDX-License-Identifier: GPL-3.0-or-later */
/* One servo's PCB around the MCU (docs/hardware.md): the bus transceiver (USART0 + direction
 * pin PD2), the LED on PB5, the H-bridge inputs from Timer0 (OCR0A / OCR0B), and the three
 * analog inputs (pot, supply sense, temperature sensor).
 *
 * The world seam: until the plant (model/plant) is wired in, the analog inputs come from
 * the fixed world values below, settable at any time; the H-bridge duties are recorded for
 * whoever drives a plant. A plant integration steps the physics with board_pwm_duty() and
 * feeds back board_set_pot_deg() / board_set_supply_v() / board_set_temperature_c(). */
#ifndef SIM_BOARD_H
#define SIM_BOARD_H

#include <stdbool.h>
#include <stdint.h>

#include "sim_time.h"
#include "uart_link.h"

struct avr_t;
struct avr_irq_t;

#define BOARD_LED_LOG 256u
#define BOARD_POT_RANGE_DEG 300.0
#define BOARD_ADC_FULL_SCALE_MV 5000.0

typedef struct {
  sim_cycles_t at;
  bool on;
} board_led_event_t;

typedef struct {
  double pot_deg;         /* output shaft angle, 0..300 over the pot track */
  double supply_v;        /* at the servo's connector */
  double temperature_c;   /* at the sensor */
} board_world_t;

typedef struct board {
  struct avr_t *avr;
  uart_link_t link;
  board_world_t world;
  /* LED (PB5). */
  bool led_on;
  uint64_t led_transitions;
  board_led_event_t led_log[BOARD_LED_LOG]; /* ring: the last BOARD_LED_LOG transitions */
  /* H-bridge inputs: OCR0A (CCW) and OCR0B (CW), 0..255. */
  uint8_t pwm_a, pwm_b;
  uint64_t adc_conversions;
  /* Called after the MCU was reset (watchdog or servo_reset), with on_reset_ctx. */
  void (*on_reset)(void *ctx);
  void *on_reset_ctx;
  /* simavr IRQs (kept for detaching / tracing). */
  struct avr_irq_t *adc_irq;
  void *reset_io; /* avr_io_t that tells the board about MCU resets */
  const void *port_b, *port_d; /* avr_ioport_t of ports B and D */
#define BOARD_PORT_IRQS 4u
  struct avr_irq_t *port_irq[BOARD_PORT_IRQS]; /* PORTD, DDRD, PORTB, DDRB change IRQs */
} board_t;

/* The world before any setter: 150 deg (centre), 9.6 V, 25 degC. */
board_world_t board_world_default(void);

/* Wires the board around avr and onto bus. Returns false if the MCU lacks a part. */
bool board_attach(board_t *board, struct avr_t *avr, bus_t *bus, const char *name);
void board_detach(board_t *board);

void board_set_pot_deg(board_t *board, double deg);
void board_set_supply_v(board_t *board, double volts);
void board_set_temperature_c(board_t *board, double celsius);

/* All three analog inputs at once, as millivolts at the pins (the plant's readings). */
void board_set_analog_mv(board_t *board, double pot_mv, double supply_mv, double temperature_mv);

/* The analog inputs in millivolts, as the ADC sees them now. */
uint32_t board_pot_mv(const board_t *board);
uint32_t board_supply_mv(const board_t *board);
uint32_t board_temperature_mv(const board_t *board);

/* Motor drive -1..+1: (OCR0A - OCR0B) / 255, positive counter-clockwise. */
double board_pwm_duty(const board_t *board);

/* The i-th LED transition from the oldest kept one (i < min(transitions, BOARD_LED_LOG)). */
const board_led_event_t *board_led_event(const board_t *board, uint64_t i);

#endif
