/* Reset-time glue, before the C runtime. Plain assembly: these run without a stack frame,
 * and naked C functions would defeat -fstack-usage.
 *
 * .init1  stack paint. Every byte from _end (= __heap_start, the end of .data/.bss/.noinit)
 *         up to RAMEND (__stack) inclusive is set to STACK_PAINT_BYTE. The firmware has no
 *         heap, so only the stack ever writes there: a host that reads RAM finds the deepest
 *         stack use as RAMEND + 1 - (the lowest address >= _end whose byte is no longer
 *         STACK_PAINT_BYTE). SP is RAMEND from reset and nothing is on the stack yet; the loop
 *         uses r24, r25, Z and no stack; 6 cycles per byte (0.15 ms on the ATmega88, 0.53 ms
 *         on the ATmega328P, with 624 B of static RAM). See docs/firmware.md "Stack paint".
 * .init3  (r1 = 0, SP set by .init2) board_reset_flags = MCUSR; MCUSR = 0 (clears WDRF); then
 *         the timed WDCE sequence sets the watchdog to reset after 250 ms, from the first
 *         instructions of boot on (a watchdog reset leaves it running at 16 ms, which .init1's
 *         0.5 ms and this are well inside). Boot until the main loop's first feed takes about
 *         2 ms (the ADC's three readings, both EEPROM slots); docs/firmware.md "Watchdog".
 */
#include <avr/io.h>

#define STACK_PAINT_BYTE 0xC5

  .section .init1, "ax", @progbits
  ldi r30, lo8(_end)
  ldi r31, hi8(_end)
  ldi r24, STACK_PAINT_BYTE
  ldi r25, hi8(__stack)
  rjmp 2f
1:
  st Z+, r24
2:
  cpi r30, lo8(__stack)
  cpc r31, r25
  brlo 1b
  breq 1b

  .section .init3, "ax", @progbits
  in r24, _SFR_IO_ADDR(MCUSR)
  sts board_reset_flags, r24
  out _SFR_IO_ADDR(MCUSR), r1
  ldi r24, _BV(WDCE) | _BV(WDE)
  sts _SFR_MEM_ADDR(WDTCSR), r24
  ldi r24, _BV(WDE) | _BV(WDP2)      /* 250 ms (WDTO_250MS), reset mode */
  sts _SFR_MEM_ADDR(WDTCSR), r24
