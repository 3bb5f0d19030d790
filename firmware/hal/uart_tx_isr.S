/* The transmit interrupts (see uart.h): USART_UDRE sends a reply's bytes after its first,
 * TIMER1_COMPA starts a reply whose Return Delay Time is long, and the spin that starts one at
 * its exact tick, which the RX interrupt (uart_rx_fast.S), TIMER1_COMPA and the main loop's late
 * start (uart.c) share. Assembly because they time the reply's first byte (the spin leaves on
 * its tick) and, for UDRE, run for every byte of every reply. Cycle counts: docs/firmware.md
 * "Execution contexts and budgets". */
#include <avr/io.h>
#include "uart.h"

/* The frame TIMER1_COMPA and USART_UDRE save (r24, SREG, r25, Z); uart_isr_return restores it. */
.macro SAVE_ISR_FRAME
  push r24
  in r24, _SFR_IO_ADDR(SREG)
  push r24
  push r25
  push r30
  push r31
.endm

/* TIMER1_COMPA: UART_COMPA_EARLY_TICKS before a WAITING reply's start tick. Spins to the exact
 * tick, starts the reply and switches COMPA off. An entry before that is a stale OCF1A from an
 * earlier match (OCR1A matches once every timer period), left set on purpose: clearing it by
 * writing TIFR1 also drops a pending OCF1B in simavr 1.6 (measured: the control tick then
 * stops for a whole timer period). Not nested in a 16-bit timer access: TIMER1_COMPB writes
 * OCR1B with interrupts off. */
  .section .text.uart_compa_isr, "ax", @progbits
  .global TIMER1_COMPA_vect
TIMER1_COMPA_vect:
  SAVE_ISR_FRAME
  lds r30, uart_tx_start_tick
  lds r31, uart_tx_start_tick + 1
  lds r24, _SFR_MEM_ADDR(TCNT1L)
  lds r25, _SFR_MEM_ADDR(TCNT1H)
  sub r24, r30
  sbc r25, r31
  adiw r24, UART_COMPA_EARLY_TICKS   /* TCNT1 - (start - early) */
  brmi 2f                            /* stale: the match is still ahead */
  rcall uart_spin_and_send
  ldi r24, _BV(OCIE1B)
  sts _SFR_MEM_ADDR(TIMSK1), r24
2:
  rjmp uart_isr_return

/* USART_UDRE: one byte per interrupt from uart_tx_bytes; with the last (uart_tx_length) it
 * hands over to TX-complete, clearing TXC0 first because simavr raises it after every byte
 * (silicon: only once the shifter runs empty). A streamed reply stalls (UDRIE off, bus still
 * driven) at the first unpublished byte; uart_reply_publish() resumes it. */
  .section .text.uart_udre_isr, "ax", @progbits
  .global USART_UDRE_vect
USART_UDRE_vect:
  SAVE_ISR_FRAME
  lds r24, uart_tx_next
  lds r25, uart_tx_published
  cp r24, r25
  breq 2f
  lds r30, uart_tx_bytes
  lds r31, uart_tx_bytes + 1
  add r30, r24
  ldi r25, 0
  adc r31, r25
  ld r25, Z
  sts _SFR_MEM_ADDR(UDR0), r25
  inc r24
  sts uart_tx_next, r24
  lds r25, uart_tx_length
  cp r24, r25
  brne 3f
  ldi r24, _BV(U2X0) | _BV(TXC0)
  sts _SFR_MEM_ADDR(UCSR0A), r24
  ldi r24, UART_UCSR0B_LAST_BYTE
  rjmp 1f
2:
  ldi r24, _BV(TXEN0)                /* stall */
1:
  sts _SFR_MEM_ADDR(UCSR0B), r24
3:
uart_isr_return:                     /* also TIMER1_COMPA's: the same registers saved */
  pop r31
  pop r30
  pop r25
  pop r24
  out _SFR_IO_ADDR(SREG), r24
  pop r24
  reti

/* Shared by USART_RX (Return Delay Time 2-5), TIMER1_COMPA and the main loop's late start
 * (uart.c): spins until TCNT1 reaches Z (the start tick less UART_SPIN_COMPENSATION_TICKS),
 * drives the bus and writes the reply's first byte; uart_sending then hands the rest to the
 * UDRE ISR. Interrupts off; clobbers r24. C entry (call-clobbered registers only):
 * uart_start_at(tick) = the spin from Z = tick. */
  .section .text.uart_spin_and_send, "ax", @progbits
  .global uart_start_at
  .global uart_spin_and_send
  .global uart_sending
uart_start_at:
  movw r30, r24
uart_spin_and_send:
  lds r24, _SFR_MEM_ADDR(TCNT1L)     /* 8 cycles a turn = 1 tick */
  cp r24, r30
  lds r24, _SFR_MEM_ADDR(TCNT1H)
  cpc r24, r31
  brmi uart_spin_and_send            /* while (int16_t)(TCNT1 - Z) < 0 */
  sbi _SFR_IO_ADDR(PORTD), UART_BUS_DIR_BIT
  ldi r24, DXL_HEADER_BYTE_ASM        /* every status packet starts with it */
  sts _SFR_MEM_ADDR(UDR0), r24       /* the reply starts here */
uart_sending:
  ldi r24, UART_UCSR0B_TALK          /* UDRIE only after the UDR0 write: simavr raises UDRE at
                                        once if enabled with no byte in flight, which would
                                        send the second byte without waiting */
  sts _SFR_MEM_ADDR(UCSR0B), r24
  ldi r24, 1
  sts uart_tx_next, r24
  ldi r24, UART_REPLY_SENDING
  sts uart_tx_state, r24
  ret
