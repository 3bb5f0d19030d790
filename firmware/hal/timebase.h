/* Timer1 timebase (docs/hardware.md "Timebase"): free-running at clk/8, one tick = 0.5 us,
 * wrapping every 32.768 ms. OCR1A belongs to the UART (Return Delay Time, uart.c); OCR1B
 * raises the control tick every TIMEBASE_TICK_PERIOD_TICKS: its ISR (tiny_isr.S, 49 cycles)
 * moves OCR1B on and counts milliseconds; the main loop runs the periodic work when it sees
 * the count change (timebase_poll).
 *
 * This header is also included by tiny_isr.S: constants first, C under !__ASSEMBLER__.
 */
#ifndef HAL_TIMEBASE_H
#define HAL_TIMEBASE_H

#define TIMEBASE_CYCLES_PER_TICK 8
#define TIMEBASE_TICKS_PER_US 2
#define TIMEBASE_TICK_PERIOD_US 1000 /* control tick and millisecond counter: 1 kHz */
#define TIMEBASE_TICK_PERIOD_TICKS (TIMEBASE_TICK_PERIOD_US * TIMEBASE_TICKS_PER_US)

#ifndef __ASSEMBLER__

#include <stdbool.h>
#include <stdint.h>

void timebase_init(void);

/* Milliseconds since power-up, wrapping at 2^16 (TIMER1_COMPB writes it). */
extern volatile uint16_t timebase_ms_count;

/* The millisecond count, read without disabling interrupts. Main loop. */
uint16_t timebase_ms(void);

/* Whether a control period has elapsed since the last call (the main loop runs one tick for
 * any number of them). Main loop. */
bool timebase_poll(void);

#endif /* __ASSEMBLER__ */
#endif
