/* Timer1 timebase. See timebase.h; the TIMER1_COMPB ISR is in tiny_isr.S. */
#include "timebase.h"

#include <avr/io.h>

volatile uint16_t timebase_ms_count; /* TIMER1_COMPB ISR */
static uint16_t ms_polled;           /* main loop: the count timebase_poll() last saw */

void timebase_init(void) {
  TCCR1A = 0;         /* normal mode, compare outputs disconnected */
  TCCR1B = _BV(CS11); /* clk/8 */
  TCNT1 = 0;
  OCR1B = TIMEBASE_TICK_PERIOD_TICKS;
  TIFR1 = _BV(OCF1A) | _BV(OCF1B) | _BV(TOV1);
  TIMSK1 = _BV(OCIE1B);
}

/* Without disabling interrupts (that would delay the RX interrupt, whose entry times the
 * replies): TIMER1_COMPB updates both bytes before the main loop runs again, so a high byte
 * read twice the same brackets a consistent low byte. */
uint16_t timebase_ms(void) {
  const volatile uint8_t *const count = (const volatile uint8_t *)&timebase_ms_count;
  uint8_t high;
  uint8_t low;
  do {
    high = count[1];
    low = count[0];
  } while (high != count[1]);
  return (uint16_t)(((uint16_t)high << 8) | low);
}

bool timebase_poll(void) {
  const uint16_t now = timebase_ms();
  const bool elapsed = now != ms_polled;
  ms_polled = now;
  return elapsed;
}
