/* Board glue (docs/hardware.md "Pins"): LED, watchdog, reset cause, idle sleep.
 * Main loop only. */
#ifndef HAL_BOARD_H
#define HAL_BOARD_H

/* The wake flag: GPIOR0 bit BOARD_WAKE_BIT, set (one SBI) by every ISR that gives the main
 * loop work (USART_RX, USART_TX, TIMER1_COMPB, EE_READY), cleared at the top of each main
 * loop pass. The sleep test then needs interrupts off for only a few cycles: a long
 * interrupts-off window would delay USART_RX, whose entry time times the replies. */
#define BOARD_WAKE_BIT 0

#ifndef __ASSEMBLER__

#include <avr/io.h>
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

/* Start of a main loop pass: forget earlier wake-ups (the pass is about to look at everything). */
static inline void board_wake_clear(void) { GPIOR0 &= (uint8_t)~_BV(BOARD_WAKE_BIT); }

/* The main loop leaves work for its next pass: no sleep before it. */
static inline void board_wake_set(void) { GPIOR0 |= _BV(BOARD_WAKE_BIT); }

/* Idle sleep, race-free: call when the pass found nothing more to do. Sleeps unless an ISR
 * set the wake flag since board_wake_clear(); SEI and SLEEP are one step (the instruction
 * after SEI always runs, so an interrupt that became pending before cannot be missed).
 * Returns with interrupts enabled. Idle mode keeps the timers, USART, ADC and EEPROM running. */
void board_sleep_unless_woken(void);

#endif /* __ASSEMBLER__ */
#endif
