/* Board glue. See board.h. */
#include "board.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#define LED_BIT PB5

/* Filled in .init3 by startup.S (MCUSR = 0 clears WDRF, then the watchdog is set to 250 ms). */
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

/* Per wake by an ISR that left no work (a byte skipped or framed by the RX ISR, the usual
 * case on a busy bus): SBIS, RJMP, CLI, SBIC, SEI, SLEEP (8 cycles). The flag is tested
 * with interrupts on first after a wake, so work found there leaves with the next byte's
 * interrupt not delayed (docs/firmware.md "Simulator traps"); the CLI test closes the race
 * with an ISR that sets it just before SLEEP. simavr 1.6 runs two instructions after SEI
 * before a pending interrupt (silicon: one) and SLEEP with one pending does not sleep: the
 * SBIS after SLEEP is that second instruction, and the interrupt is taken before the loop
 * could reach the CLI. */
void board_sleep_unless_woken(void) {
  __asm__ __volatile__("1: cli\n\t"
                       "sbic %[gpior0], %[wake]\n\t"
                       "rjmp 2f\n\t"
                       "sei\n\t"
                       "sleep\n\t"
                       "sbis %[gpior0], %[wake]\n\t"
                       "rjmp 1b\n\t"
                       "2: sei\n\t" /* after a wake with work: already on */
                       ::[gpior0] "I"(_SFR_IO_ADDR(GPIOR0)),
                       [wake] "I"(BOARD_WAKE_BIT)
                       : "memory");
}
