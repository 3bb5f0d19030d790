/* Two small ISRs in assembly, so they save only what they touch and stay short: each one
 * that runs just before the USART_RX or TIMER1_COMPA ISR delays it, and those time replies
 * (docs/firmware.md "Reply timing"). Cycle counts include the 4-cycle response and the
 * vector JMP.
 *
 * TIMER1_COMPB (timebase.c), 45 cycles, every 1 ms: OCR1B += TIMEBASE_TICK_PERIOD_TICKS and
 *   timebase_ms_count += 1. Counting here, not in the main loop, keeps the millisecond
 *   count right however long the main loop is busy (the packet finder's worst case on
 *   garbage is tens of milliseconds).
 * EE_READY (nvm.c), 13 cycles: raised for as long as the EEPROM is ready while EERIE is set;
 *   it only wakes the main loop, so it switches EERIE off (CBI: no register, no SREG).
 */
#include <avr/io.h>
#include "timebase.h"

  .section .text.tiny_isr, "ax", @progbits

  .global TIMER1_COMPB_vect
TIMER1_COMPB_vect:
  push r24
  in r24, _SFR_IO_ADDR(SREG)
  push r24
  push r25
  lds r24, _SFR_MEM_ADDR(OCR1BL)
  lds r25, _SFR_MEM_ADDR(OCR1BH)
  subi r24, lo8(-(TIMEBASE_TICK_PERIOD_TICKS))
  sbci r25, hi8(-(TIMEBASE_TICK_PERIOD_TICKS))
  sts _SFR_MEM_ADDR(OCR1BH), r25     /* 16-bit write: high byte first */
  sts _SFR_MEM_ADDR(OCR1BL), r24
  lds r24, timebase_ms_count
  lds r25, timebase_ms_count + 1
  adiw r24, 1
  sts timebase_ms_count + 1, r25
  sts timebase_ms_count, r24
  pop r25
  pop r24
  out _SFR_IO_ADDR(SREG), r24
  pop r24
  reti

  .global EE_READY_vect
EE_READY_vect:
  cbi _SFR_IO_ADDR(EECR), EERIE
  reti
