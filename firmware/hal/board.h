/* Board glue (docs/hardware.md "Pins"): LED, watchdog, reset cause, idle sleep.
 * Main loop only. */
#ifndef HAL_BOARD_H
#define HAL_BOARD_H

#include <stdbool.h>
#include <stdint.h>

/* MCUSR as found at reset (PORF, EXTRF, BORF, WDRF), kept in .noinit; MCUSR itself is
 * cleared and the watchdog stopped in .init3, before C starts (a watchdog reset leaves the
 * watchdog running at 16 ms). */
extern uint8_t board_reset_flags;

/* LED pin as output, off. */
void board_init(void);

void board_led_set(bool on);

/* Watchdog at 250 ms; the main loop resets it every pass (it never blocks: EEPROM writes are
 * interleaved, one byte per pass, see nvm.h). */
void board_watchdog_start(void);
void board_watchdog_kick(void);

/* Idle sleep, race-free. Call with interrupts disabled, after deciding there is nothing to do:
 * enables interrupts and sleeps in one step (the instruction after SEI always runs, so an
 * interrupt that became pending before cannot be missed), returns with interrupts enabled
 * after the ISR that woke the CPU. Idle mode keeps the timers, USART, ADC and EEPROM running. */
void board_sleep_enable_interrupts(void);

#endif
