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
 * cleared and the watchdog set to 250 ms in .init3, before C starts (startup.S). */
extern uint8_t board_reset_flags;

/* LED pin as output, off. */
void board_init(void);

void board_led_set(bool on);

/* The watchdog (250 ms, running from .init3): the main loop feeds it only when the control
 * tick and the receive path have made progress since the last feed (main.c feed_watchdog). */
static inline void board_watchdog_kick(void) { __asm__ __volatile__("wdr" ::: "memory"); }

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
