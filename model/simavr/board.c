/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "board.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <avr_adc.h>
#include <avr_ioport.h>
#include <avr_timer.h>
#include <sim_avr.h>
#include <sim_io.h>

#include "simavr_patch.h"

#define PIN_DIRECTION 2 /* PD2 */
#define PIN_LED 5       /* PB5 */

/* An avr_io_t of our own, so avr_reset() (watchdog) tells the board. */
typedef struct {
  avr_io_t io;
  board_t *board;
} board_io_t;

board_world_t board_world_default(void) {
  return (board_world_t){.pot_deg = 150.0, .supply_v = 9.6, .temperature_c = 25.0};
}

static avr_ioport_t *find_port(avr_t *avr, char name) {
  for (avr_io_t *io = avr->io_port; io; io = io->next) {
    if (io->irq_ioctl_get == (uint32_t)AVR_IOCTL_IOPORT_GETIRQ(name) && io->kind && strcmp(io->kind, "port") == 0) {
      return (avr_ioport_t *)io;
    }
  }
  return NULL;
}

static bool pin_driven_high(avr_t *avr, const void *port_io, int pin) {
  const avr_ioport_t *port = port_io;
  const uint8_t mask = (uint8_t)(1u << pin);
  return (avr->data[port->r_ddr] & mask) && (avr->data[port->r_port] & mask);
}

static void update_direction(board_t *board) {
  uart_link_set_driving(&board->link, pin_driven_high(board->avr, board->port_d, PIN_DIRECTION));
}

static void update_led(board_t *board) {
  const bool on = pin_driven_high(board->avr, board->port_b, PIN_LED);
  if (on == board->led_on) {
    return;
  }
  board->led_on = on;
  board->led_log[board->led_transitions % BOARD_LED_LOG] = (board_led_event_t){.at = board->avr->cycle, .on = on};
  board->led_transitions++;
}

static void port_d_changed(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  (void)value;
  update_direction(param);
}

static void port_b_changed(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  (void)value;
  update_led(param);
}

static void pwm_a_changed(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  ((board_t *)param)->pwm_a = (uint8_t)value;
}

static void pwm_b_changed(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  ((board_t *)param)->pwm_b = (uint8_t)value;
}

static uint32_t clamp_mv(double mv) {
  if (!(mv > 0.0)) {
    return 0;
  }
  return mv > BOARD_ADC_FULL_SCALE_MV ? (uint32_t)BOARD_ADC_FULL_SCALE_MV : (uint32_t)lround(mv);
}

uint32_t board_pot_mv(const board_t *board) {
  return clamp_mv(board->world.pot_deg / BOARD_POT_RANGE_DEG * BOARD_ADC_FULL_SCALE_MV);
}

uint32_t board_supply_mv(const board_t *board) { return clamp_mv(board->world.supply_v / 5.0 * 1000.0); }

uint32_t board_temperature_mv(const board_t *board) {
  return clamp_mv(500.0 + 10.0 * board->world.temperature_c);
}

/* simavr 1.6: the ADC converts with mV x 1023 / Vref (floored); silicon gives Vin x 1024 / Vref
 * (floored, at most 1023). The board hands simavr the smallest whole millivolt value that
 * makes simavr return the silicon's count, so 2500 mV reads 512 as on a board. */
static uint32_t simavr_adc_input_mv(uint32_t mv) {
  uint32_t count = (uint32_t)(((uint64_t)mv * 1024u) / (uint32_t)BOARD_ADC_FULL_SCALE_MV);
  if (count > 1023u) {
    count = 1023u;
  }
  return (uint32_t)((count * (uint32_t)BOARD_ADC_FULL_SCALE_MV + 1022u) / 1023u);
}

static void feed_adc(board_t *board) {
  if (!board->adc_irq) {
    return;
  }
  avr_raise_irq(board->adc_irq + ADC_IRQ_ADC0, simavr_adc_input_mv(board_pot_mv(board)));
  avr_raise_irq(board->adc_irq + ADC_IRQ_ADC1, simavr_adc_input_mv(board_supply_mv(board)));
  avr_raise_irq(board->adc_irq + ADC_IRQ_ADC2, simavr_adc_input_mv(board_temperature_mv(board)));
}

static void adc_triggered(struct avr_irq_t *irq, uint32_t value, void *param) {
  (void)irq;
  (void)value;
  board_t *board = param;
  board->adc_conversions++;
  feed_adc(board);
}

static avr_cycle_count_t after_reset(avr_t *avr, avr_cycle_count_t when, void *param) {
  (void)when;
  (void)param;
  simavr_extint_poll_off(avr);
  return 0;
}

static void board_io_reset(avr_io_t *io) {
  board_t *board = ((board_io_t *)io)->board;
  /* simavr 1.6: the port IRQs notify on change only and remember their last value, and
   * avr_reset() zeroes the registers behind their back, so a PD2 written high again after the
   * reset would go unnoticed. Tell them about the zeros. */
  for (size_t i = 0; i < BOARD_PORT_IRQS; i++) {
    if (board->port_irq[i]) {
      avr_raise_irq(board->port_irq[i], 0);
    }
  }
  uart_link_reset(&board->link);
  update_led(board);
  board->pwm_a = board->pwm_b = 0;
  if (board->on_reset) {
    board->on_reset(board->on_reset_ctx);
  }
  /* simavr 1.6: the other modules reset after this one, and extint turns its strict level
   * mode (the per-cycle INT0 poll) back on: switch it off once they are done. */
  avr_cycle_timer_register(board->avr, 0, after_reset, board);
}

static struct avr_irq_t *notify(avr_t *avr, uint32_t ctl, int index, avr_irq_notify_t fn, board_t *board) {
  struct avr_irq_t *irq = avr_io_getirq(avr, ctl, index);
  if (irq) {
    avr_irq_register_notify(irq, fn, board);
  }
  return irq;
}

bool board_attach(board_t *board, avr_t *avr, bus_t *bus, const char *name) {
  memset(board, 0, sizeof(*board));
  board->avr = avr;
  board->world = board_world_default();
  board->port_b = find_port(avr, 'B');
  board->port_d = find_port(avr, 'D');
  if (!board->port_b || !board->port_d || !uart_link_attach(&board->link, avr, bus, name)) {
    return false;
  }
  board->port_irq[0] = notify(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), IOPORT_IRQ_REG_PORT, port_d_changed, board);
  board->port_irq[1] = notify(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), IOPORT_IRQ_DIRECTION_ALL, port_d_changed, board);
  board->port_irq[2] = notify(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), IOPORT_IRQ_REG_PORT, port_b_changed, board);
  board->port_irq[3] = notify(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), IOPORT_IRQ_DIRECTION_ALL, port_b_changed, board);
  notify(avr, AVR_IOCTL_TIMER_GETIRQ('0'), TIMER_IRQ_OUT_PWM0, pwm_a_changed, board);
  notify(avr, AVR_IOCTL_TIMER_GETIRQ('0'), TIMER_IRQ_OUT_PWM1, pwm_b_changed, board);
  board->adc_irq = avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, 0);
  if (board->adc_irq) {
    avr_irq_register_notify(board->adc_irq + ADC_IRQ_OUT_TRIGGER, adc_triggered, board);
  }
  feed_adc(board);

  board_io_t *bio = calloc(1, sizeof(*bio));
  if (!bio) {
    return false;
  }
  bio->io.kind = "ax12-board";
  bio->io.reset = board_io_reset;
  bio->board = board;
  avr_register_io(avr, &bio->io);
  board->reset_io = bio;
  update_direction(board);
  update_led(board);
  simavr_extint_poll_off(avr);
  return true;
}

void board_detach(board_t *board) {
  /* Call after avr_terminate(): simavr no longer references the io module. */
  free(board->reset_io);
  board->reset_io = NULL;
}

void board_set_pot_deg(board_t *board, double deg) {
  board->world.pot_deg = deg;
  feed_adc(board);
}

void board_set_supply_v(board_t *board, double volts) {
  board->world.supply_v = volts;
  feed_adc(board);
}

void board_set_temperature_c(board_t *board, double celsius) {
  board->world.temperature_c = celsius;
  feed_adc(board);
}

void board_set_analog_mv(board_t *board, double pot_mv, double supply_mv, double temperature_mv) {
  board->world.pot_deg = pot_mv * BOARD_POT_RANGE_DEG / BOARD_ADC_FULL_SCALE_MV;
  board->world.supply_v = supply_mv * 5.0 / 1000.0;
  board->world.temperature_c = (temperature_mv - 500.0) / 10.0;
  feed_adc(board);
}

double board_pwm_duty(const board_t *board) { return ((double)board->pwm_a - (double)board->pwm_b) / 255.0; }

const board_led_event_t *board_led_event(const board_t *board, uint64_t i) {
  const uint64_t kept = board->led_transitions < BOARD_LED_LOG ? board->led_transitions : BOARD_LED_LOG;
  if (i >= kept) {
    return NULL;
  }
  return &board->led_log[(board->led_transitions - kept + i) % BOARD_LED_LOG];
}
