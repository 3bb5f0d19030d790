/* Open AX-12 firmware: the main loop that ties the protocol core (firmware/core) and the link
 * layer (firmware/link) to the board (firmware/hal). SPDX-License-Identifier: MIT (the
 * firmware; the simavr host that runs it is GPL-3.0-or-later, see docs/firmware.md).
 *
 * Execution contexts (docs/firmware.md): the ISRs in hal/ move bytes and start replies;
 * everything else runs here, in one loop that never blocks:
 *   0. the watchdog, fed only when the tick and the receive path made progress (feed_watchdog);
 *   1. the link (dxl_link.h): what follows a reply that has left, then received bytes to
 *      packets handled and replies started;
 *   2. control tick (1 kHz): the link's timeouts, ADC into the sensors, control_tick() (which
 *      writes the Present items from them), LED, the link's ready PING reply;
 *   3. EEPROM: one byte of a pending settings write when the EEPROM is ready (nvm.h);
 *   4. idle sleep unless an ISR set the wake flag during the pass.
 */
#include <avr/interrupt.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "adc.h"
#include "board.h"
#include "control.h"
#include "dxl_link.h"
#include "dxl_link_port.h"
#include "dxl_servo.h"
#include "motor.h"
#include "nvm.h"
#include "timebase.h"
#include "uart.h"

/* Power-up blink (docs/policy.md "Power-up"): on-off twice, BOOT_BLINK_MS each phase. */
#define BOOT_BLINK_MS 100u
#define BOOT_BLINK_PHASES 4u

/* ADC conversions, one per control tick: the pot every other tick. */
static const DXL_FLASH uint8_t adc_sequence[] = {ADC_CH_POT, ADC_CH_SUPPLY, ADC_CH_POT, ADC_CH_TEMP};
#define ADC_SEQUENCE_LENGTH (sizeof adc_sequence / sizeof adc_sequence[0])

/* The servo's state, its control table first (servo.table[CT_SIZE]); external so that it
 * keeps its name through LTO: a debugger reads it as `servo` (docs/debugging.md). */
dxl_servo_t servo;
static dxl_link_t link;

static uint8_t adc_slot;
static dxl_sensors_t sensors; /* the latest reading of each ADC channel, in the control's units */
/* Control ticks run since power-up (wrapping): a host reads it by symbol to count missed ticks. */
volatile uint16_t control_tick_count;
/* What the last watchdog feed saw (feed_watchdog). */
static uint16_t fed_tick_count;
static uint8_t fed_rx_tail;

/* Test builds only (AX12_INJECT_HANG in firmware/CMakeLists.txt; docs/firmware.md "Watchdog"):
 * from HANG_AFTER_TICKS control ticks after power-up on, the main loop, the control tick or
 * the receive path stops. Never defined in a product build. */
#define HANG_AFTER_TICKS 1500u
#if defined(AX12_INJECT_HANG_MAIN) || defined(AX12_INJECT_HANG_TICK) || defined(AX12_INJECT_HANG_RX)
static bool hang_due(void) { return control_tick_count >= HANG_AFTER_TICKS; }
#endif
static uint8_t boot_blink_ms; /* into the current phase */
static uint8_t boot_blink_phase;

static void service_rx(void) {
#ifdef AX12_INJECT_HANG_RX
  if (hang_due()) {
    return; /* the receive path takes no byte any more */
  }
#endif
  dxl_link_service_rx(&link, &servo);
}

/* A finished conversion into the sensors the control tick reads (it writes the Present*
 * items from them). */
static void take_adc(uint8_t channel, uint16_t reading) {
  switch (channel) {
  case ADC_CH_POT:
    sensors.position_counts = reading;
    break;
  case ADC_CH_SUPPLY:
    sensors.voltage_dv = adc_supply_decivolts(reading);
    break;
  default:
    sensors.temperature_c = adc_temperature_c(reading);
    break;
  }
}

static void update_led(void) {
  if (boot_blink_phase < BOOT_BLINK_PHASES) {
    board_led_set((boot_blink_phase & 1u) == 0);
    if (++boot_blink_ms == BOOT_BLINK_MS) {
      boot_blink_ms = 0;
      boot_blink_phase++;
    }
    return;
  }
  board_led_set(control_led_on()); /* register 25, or the alarm blink (dxl_control.h) */
}

static void service_tick(void) {
  if (!timebase_poll()) {
    return;
  }
  dxl_link_tick(&link, &servo, timebase_ms());
  if (!adc_busy()) {
    take_adc(adc_sequence[adc_slot], adc_result());
    adc_slot = (uint8_t)((adc_slot + 1u) % ADC_SEQUENCE_LENGTH);
    adc_start(adc_sequence[adc_slot]);
  }
#ifdef AX12_INJECT_HANG_TICK
  if (hang_due()) {
    return; /* the control tick does not run any more */
  }
#endif
  const uint8_t conditions = control_tick(&servo, &sensors);
  __asm__ __volatile__("" ::: "memory"); /* the RX ISR may have armed meanwhile */
  control_tick_count++;
  update_led();
  dxl_link_conditions_changed(&link, &servo, conditions);
}

/* The watchdog (docs/firmware.md "Watchdog"), fed here in the main loop only when, since the
 * last feed, a control tick has run and the receive path has taken bytes from the ring or has
 * none waiting (the ring's tail and head as the link layer reads them, dxl_link_port.h): a hang
 * of the loop, of the tick or of the receive path starves it, and 250 ms later the MCU resets.
 * (Bytes wait legitimately while the sniff holds a packet or a reply is on the wire: at the
 * slowest baud at most about 130 ms.) */
static void feed_watchdog(void) {
  const uint16_t ticks = control_tick_count;
  const uint8_t tail = dxl_link_port_rx_tail(NULL);
  if (ticks != fed_tick_count && (tail != fed_rx_tail || tail == dxl_link_port_rx_head(NULL))) {
    fed_tick_count = ticks;
    fed_rx_tail = tail;
    board_watchdog_kick();
  }
}

/* Work that no ISR flags: an EEPROM byte to write. If it becomes possible after this test,
 * EE_READY is already pending and ends the sleep at once. */
static bool work_without_interrupt(void) { return nvm_work_ready(); }

static void power_up(void) {
  board_init();
  motor_init();
  timebase_init();
  adc_init();
  /* Present values first: Goal Position = Present Position (docs/policy.md "Power-up"). */
  for (uint8_t slot = 1; slot < ADC_SEQUENCE_LENGTH; slot++) { /* every channel once */
    const uint8_t channel = adc_sequence[slot];
    take_adc(channel, adc_read_blocking(channel));
  }
  const uint8_t *const stored = nvm_load();
  dxl_servo_power_up(&servo, stored, sensors.position_counts); /* the first control tick writes
                                                                 the other Present items */
  if (stored == NULL) {
    nvm_persist(); /* no valid slot: factory defaults, written back */
  }
  adc_start(adc_sequence[0]);
  dxl_link_init(&link, &servo, NULL);
  uart_init(servo.table[CT_ADDR_BAUD_RATE]);
}

int main(void) {
  power_up();
  sei();
  for (;;) {
    board_wake_clear();
    feed_watchdog();
#ifdef AX12_INJECT_HANG_MAIN
    while (hang_due()) {
      /* the main loop is stuck */
    }
#endif
    dxl_link_service_reply(&link, &servo);
    service_rx();
    service_tick();
    nvm_service(servo.table);
    /* Work an ISR leaves (a received byte, a tick, a reply sent) sets the wake flag; a pass
     * that stops early with bytes waiting (a reply under way) is woken by the reply's
     * TX-complete. */
    if (!work_without_interrupt()) {
      board_sleep_unless_woken();
    }
  }
}
