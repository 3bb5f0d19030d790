/* Two small ISRs in assembly, so they save only what they touch and stay short: each one
 * that runs just before the USART_RX or TIMER1_COMPA ISR delays it, and those time replies
 * (docs/firmware.md "Reply timing"). Cycle counts include the 4-cycle response and the
 * vector's jump (RJMP on the ATmega88; the ATmega328P's JMP adds one cycle).
 *
 * TIMER1_COMPB (timebase.c), 49 cycles, every 1 ms: OCR1B += TIMEBASE_TICK_PERIOD_TICKS and
 *   timebase_ms_count += 1. Counting here, not in the main loop, keeps the millisecond
 *   count right however long a main-loop pass takes (one that handles a packet, or rejects
 *   a candidate in garbage, takes thousands of cycles). Interrupts are enabled again after
 *   the first 8 cycles of its code, so a USART_RX interrupt (which stamps the byte's time)
 *   waits at most that long;
 *   COMPB cannot nest into itself (its next match is 1 ms later). No nested ISR reads the
 *   millisecond count; the OCR1B write is done with interrupts off, because a 16-bit timer
 *   access in a nested ISR (TCNT1 read, OCR1A write) would clobber the shared TEMP byte.
 * EE_READY (nvm.c), 14 cycles: raised for as long as the EEPROM is ready while EERIE is set;
 *   it only wakes the main loop (wake flag, board.h), so it switches EERIE off (CBI, SBI:
 *   no register, no SREG).
 */
#include <avr/io.h>
#include "board.h"
#include "timebase.h"

  .section .text.tiny_isr, "ax", @progbits

  .global TIMER1_COMPB_vect
TIMER1_COMPB_vect:
  push r24
  in r24, _SFR_IO_ADDR(SREG)
  push r24
  sei                                /* USART_RX may nest: its entry times replies */
  sbi _SFR_IO_ADDR(GPIOR0), BOARD_WAKE_BIT
  push r25
  lds r24, timebase_ms_count
  lds r25, timebase_ms_count + 1
  adiw r24, 1
  sts timebase_ms_count + 1, r25
  sts timebase_ms_count, r24
  lds r24, _SFR_MEM_ADDR(OCR1BL)     /* reading OCR1B does not use the TEMP register */
  lds r25, _SFR_MEM_ADDR(OCR1BH)
  subi r24, lo8(-(TIMEBASE_TICK_PERIOD_TICKS))
  sbci r25, hi8(-(TIMEBASE_TICK_PERIOD_TICKS))
  cli                                /* the 16-bit write shares TEMP with the nested ISRs' */
  sts _SFR_MEM_ADDR(OCR1BH), r25     /* 16-bit write: high byte first */
  sts _SFR_MEM_ADDR(OCR1BL), r24
  sei
  pop r25
  pop r24
  out _SFR_IO_ADDR(SREG), r24
  pop r24
  reti

  .global EE_READY_vect
EE_READY_vect:
  cbi _SFR_IO_ADDR(EECR), EERIE
  sbi _SFR_IO_ADDR(GPIOR0), BOARD_WAKE_BIT
  reti
