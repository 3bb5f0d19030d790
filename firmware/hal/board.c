/* Board glue. See board.h. */
#include "board.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <avr/wdt.h>

#define LED_BIT PB5

/* Filled in .init3 by startup.S (MCUSR = 0 clears WDRF, then the watchdog is switched off). */
uint8_t board_reset_flags __attribute__((section(".noinit")));

void board_init(void) {
  PORTB &= (uint8_t)~_BV(LED_BIT);
  DDRB |= _BV(LED_BIT);
  /* Idle mode, sleep enabled for good: SLEEP appears only in board_sleep_unless_woken() (the
   * datasheet's set-SE-just-before advice guards against a stray SLEEP; there is none), which
   * saves setting and clearing SE on every pass. */
  set_sleep_mode(SLEEP_MODE_IDLE);
  sleep_enable();
}

void board_led_set(bool on) {
  if (on) {
    PORTB |= _BV(LED_BIT);
  } else {
    PORTB &= (uint8_t)~_BV(LED_BIT);
  }
}

void board_watchdog_start(void) { wdt_enable(WDTO_250MS); }

void board_watchdog_kick(void) { wdt_reset(); }

void board_sleep_unless_woken(void) {
  cli();
  while (!(GPIOR0 & _BV(BOARD_WAKE_BIT))) {
    sei();
    sleep_cpu();
    /* simavr 1.6 runs two instructions after SEI before a pending interrupt (silicon: one),
     * and SLEEP with one pending does not sleep: without this NOP the CLI below could come
     * first, and the loop would spin with the interrupt never taken. */
    __asm__ __volatile__("nop");
    if (GPIOR0 & _BV(BOARD_WAKE_BIT)) {
      break; /* work: back with interrupts on, so the next byte's interrupt is not delayed */
    }
    cli(); /* an ISR that left no work (a byte the sniff framed): sleep on */
  }
  sei();
}
