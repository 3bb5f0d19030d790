/* USART_RX ISR (see uart.h). Assembly because it is on the measured reply path: every cycle
 * before the UDR0 write adds to the reply latency at Return Delay Time 0, and its entry point
 * must be fixed so the tick it records can be compensated (UART_RX_READ_CYCLES).
 *
 * Every byte: record TCNT1 (uart_rx_tick), count a frame error / data overrun flagged for it,
 * append it to the ring (or count it dropped when the ring is full).
 * When a reply is ARMED, the first uart_tx_skip bytes pass (counted down); the next is the
 * checksum of the packet the main loop prepared:
 *   differs  -> IDLE (the main loop handles the packet as usual: Checksum Error etc.);
 *   matches  -> start the reply, by uart_tx_mode:
 *     NOW    write the first byte at once (set PD2, UDR0, receiver off, UDRE interrupt on);
 *     SPIN   busy-wait until TCNT1 reaches start = tick + delay - UART_SPIN_COMPENSATION_TICKS,
 *            then as NOW (Return Delay Time 2..6: at most about 130 cycles of spinning);
 *     TIMER  uart_tx_start_tick = start, OCR1A = start - UART_COMPA_EARLY_TICKS;
 *            TIMER1_COMPA spins from there to start, then as NOW.
 *
 * PING sniff (uart_sniff 0..3, set up by the main loop with the ring empty): the bytes
 * FF FF ID 02 are matched as they arrive; at the LENGTH the loaded reply (the ready PING
 * reply) is ARMED as above, so neither the main loop's latency nor its long passes (the
 * control tick) delay it. Any other byte ends the sniff (UART_SNIFF_OFF).
 *
 * Registers: r18:r19 tick, r24 scratch, r25 the byte, Z. r1 is not assumed to be 0.
 * Cycles, counting the 4-cycle interrupt response and the vector JMP (docs/firmware.md):
 * common path 78 (simavr measures 69: it charges no response); an armed NOW start writes
 * UDR0 at cycle 57 (52 in simavr).
 */
#include <avr/io.h>
#include "uart.h"

  .section .text.uart_rx_isr, "ax", @progbits
/* (Placed before the vector for the branch range.) PING sniff: byte r24 (0..3) of FF FF ID 02. At the ID the checksum that completes the
 * PING, ~(ID + 2 + 1) = 0xFC - ID, goes to uart_tx_checksum (unused while IDLE); at the
 * LENGTH the loaded reply is armed with skip 1 (the instruction passes, the checksum
 * compares), so the reply starts from the checksum's own RX interrupt. */
.Lsniff:
  cpi r24, 2
  breq 6f
  brsh 7f
  cpi r25, DXL_HEADER_BYTE_ASM       /* 0, 1: header */
  brne .Lsniff_off
  rjmp .Lsniff_next
6:
  lds r30, uart_sniff_id             /* 2: this servo's ID */
  cp r25, r30
  brne .Lsniff_off
  ldi r30, 0xFC
  sub r30, r25
  sts uart_tx_checksum, r30
  rjmp .Lsniff_next
7:
  cpi r25, 2                         /* 3: LENGTH 2 */
  brne .Lsniff_off
  ldi r30, 1
  sts uart_tx_skip, r30
  ldi r30, UART_REPLY_ARMED
  sts uart_tx_state, r30
.Lsniff_next:
  inc r24                            /* 3 -> UART_SNIFF_ARMED */
  sts uart_sniff, r24
  rjmp .Lstore
.Lsniff_off:
  ldi r24, UART_SNIFF_OFF
  sts uart_sniff, r24
  rjmp .Lstore

  .global USART_RX_vect
USART_RX_vect:
  push r18
  push r19
  lds r18, _SFR_MEM_ADDR(TCNT1L)     /* UART_RX_READ_CYCLES after the interrupt was raised */
  lds r19, _SFR_MEM_ADDR(TCNT1H)
  push r24
  in r24, _SFR_IO_ADDR(SREG)
  push r24
  push r25
  push r30
  push r31
  lds r24, _SFR_MEM_ADDR(UCSR0A)     /* FE0/DOR0 describe the byte in UDR0: read it first */
  lds r25, _SFR_MEM_ADDR(UDR0)
  andi r24, _BV(FE0) | _BV(DOR0)
  breq 1f
  lds r24, uart_rx_line_error_count
  inc r24
  breq 1f                            /* saturate at 255 */
  sts uart_rx_line_error_count, r24
1:
  lds r24, uart_sniff
  cpi r24, UART_SNIFF_ARMED
  brlo .Lsniff                       /* a PING sniff is under way (reply IDLE) */
  lds r24, uart_tx_state
  cpi r24, UART_REPLY_ARMED
  breq .Larmed

.Lstore:
  lds r24, uart_rx_head
  lds r30, uart_rx_tail
  mov r31, r24
  sub r31, r30                       /* bytes in the ring */
  cpi r31, UART_RX_RING_BYTES
  brsh .Lfull
  mov r30, r24
  andi r30, UART_RX_RING_MASK
  ldi r31, 0
  subi r30, lo8(-(uart_rx_ring))
  sbci r31, hi8(-(uart_rx_ring))
  st Z, r25
  inc r24
  sts uart_rx_head, r24              /* publish the byte after it is stored */
.Ltick:
  sts uart_rx_tick, r18
  sts uart_rx_tick + 1, r19
  pop r31
  pop r30
  pop r25
  pop r24
  out _SFR_IO_ADDR(SREG), r24
  pop r24
  pop r19
  pop r18
  reti

.Lfull:
  lds r24, uart_rx_dropped_count
  inc r24
  breq .Ltick                        /* saturate at 255 */
  sts uart_rx_dropped_count, r24
  rjmp .Ltick

.Larmed:
  lds r24, uart_tx_skip
  subi r24, 1
  brcs 4f                            /* skip was 0: this is the checksum */
  sts uart_tx_skip, r24              /* a byte before the checksum */
  rjmp .Lstore
4:
  lds r24, uart_tx_checksum
  cp r25, r24
  breq 2f
  ldi r24, UART_REPLY_IDLE
  sts uart_tx_state, r24
  rjmp .Lstore
2:
  lds r24, uart_tx_mode
  cpi r24, UART_START_NOW
  breq .Lsend
  lds r30, uart_tx_delay_ticks
  lds r31, uart_tx_delay_ticks + 1
  add r30, r18
  adc r31, r19
  sbiw r30, UART_SPIN_COMPENSATION_TICKS /* Z = the tick at which to leave the spin */
  cpi r24, UART_START_TIMER
  breq .Ltimer
3:
  lds r24, _SFR_MEM_ADDR(TCNT1L)     /* 8 cycles a turn = 1 tick */
  cp r24, r30
  lds r24, _SFR_MEM_ADDR(TCNT1H)
  cpc r24, r31
  brmi 3b                            /* while (int16_t)(TCNT1 - Z) < 0 */
.Lsend:
  sbi _SFR_IO_ADDR(PORTD), UART_BUS_DIR_BIT
  lds r24, uart_tx_first
  sts _SFR_MEM_ADDR(UDR0), r24       /* the reply starts here */
  ldi r24, UART_UCSR0B_TALK          /* UDRIE after the UDR0 write: see uart.c */
  sts _SFR_MEM_ADDR(UCSR0B), r24
  ldi r24, 1
  sts uart_tx_next, r24
  ldi r24, UART_REPLY_SENDING
  sts uart_tx_state, r24
  rjmp .Lstore

.Ltimer:
  sts uart_tx_start_tick + 1, r31    /* TIMER1_COMPA spins until this tick */
  sts uart_tx_start_tick, r30
  sbiw r30, UART_COMPA_EARLY_TICKS
  sts _SFR_MEM_ADDR(OCR1AH), r31     /* 16-bit write: high byte first */
  sts _SFR_MEM_ADDR(OCR1AL), r30
  ldi r24, _BV(OCF1A)
  out _SFR_IO_ADDR(TIFR1), r24       /* no stale match */
  ldi r24, _BV(OCIE1A) | _BV(OCIE1B)
  sts _SFR_MEM_ADDR(TIMSK1), r24
  ldi r24, UART_REPLY_WAITING
  sts uart_tx_state, r24
  rjmp .Lstore
