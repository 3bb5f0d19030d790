/* USART_RX ISR (see uart.h). Assembly because it is on the measured reply path: every cycle
 * before the UDR0 write adds to the reply latency at Return Delay Time 0, and its entry point
 * must be fixed so the tick it records can be compensated (UART_RX_READ_CYCLES).
 *
 * Every byte: record TCNT1 (uart_rx_tick), count a frame error / data overrun flagged for it,
 * append it to the ring (or count it dropped when the ring is full).
 * When a reply is ARMED (by the sniff below), this byte is the checksum of its packet:
 *   differs  -> IDLE (the main loop handles the packet as usual: Checksum Error etc.);
 *   matches  -> start the reply, by uart_tx_mode:
 *     NOW    write the first byte at once (set PD2, UDR0, receiver off, UDRE interrupt on);
 *     SPIN   busy-wait until TCNT1 reaches start = tick + delay - UART_SPIN_COMPENSATION_TICKS,
 *            then as NOW (Return Delay Time 2..6: at most about 130 cycles of spinning);
 *     TIMER  uart_tx_start_tick = start, OCR1A = start - UART_COMPA_EARLY_TICKS;
 *            TIMER1_COMPA spins from there to start, then as NOW.
 *
 * The sniff (uart_sniff 0..UART_SNIFF_BODY, set up by the main loop with the ring and the
 * finder empty): the bytes FF FF ID LENGTH INSTRUCTION PARAMS of a packet to this servo
 * whose instruction is in uart_sniff_mask (and, for a WRITE, whose start address is past the
 * EEPROM area) are framed and summed as they arrive; at the last byte before the checksum
 * the reply is ARMED as above, so neither the main loop's latency nor its long passes (the
 * control tick) delay it. A PING (LENGTH 2) starts the loaded ready reply; any other packet
 * streams the loaded reply's header FF FF ID, and the UDRE ISR waits for the main loop to
 * publish the rest. Any other byte ends the sniff (UART_SNIFF_OFF).
 *
 * Registers: r18:r19 tick, r24 scratch, r25 the byte, Z. r1 is not assumed to be 0.
 * The armed state is tested first and Z is saved only after the UDR0 write on the NOW path,
 * which is the Return Delay Time 0-1 latency. Cycle counts: docs/firmware.md.
 */
#include <avr/io.h>
#include "board.h"
#include "uart.h"

  .section .text.uart_rx_isr, "ax", @progbits
/* (Placed before the vector for the branch range.) The sniff: r24 = uart_sniff (its state
 * before this byte, 0..UART_SNIFF_BODY), r25 = the byte. Each state either moves on, or ends
 * the sniff (UART_SNIFF_OFF: the finder handles the packet, the late path answers it). */
.Lsniff:
  lds r30, uart_rx_head              /* held bytes: past UART_SNIFF_MAX_HELD the finder takes over */
  lds r31, uart_rx_tail
  sub r30, r31
  cpi r30, UART_SNIFF_MAX_HELD
  brsh .Lsniff_off
  cpi r24, UART_SNIFF_ID
  brlo .Lsn_header                   /* 0, 1: FF FF */
  breq .Lsn_id
  cpi r24, UART_SNIFF_INSTRUCTION
  brlo .Lsn_length
  breq .Lsn_instruction
  cpi r24, UART_SNIFF_SKIP_CHECKSUM
  breq 9f
  rjmp .Lsn_param
9:
  rjmp .Lsn_skip_checksum
.Lsn_header:
  cpi r25, DXL_HEADER_BYTE_ASM
  brne .Lsniff_off
  inc r24
  rjmp .Lsniff_next
.Lsn_id:
  cpi r25, DXL_HEADER_BYTE_ASM       /* a further FF: still the header */
  breq .Lsn_keep
  cpi r25, DXL_ID_BROADCAST_ASM      /* acted on by every servo: the finder's */
  breq .Lsniff_off
  ldi r30, 0
  lds r31, uart_sniff_id
  cpse r25, r31
  ldi r30, 1                         /* another servo's: framed, then dropped */
  sts uart_sniff_skip, r30
  sts uart_sniff_sum, r25
  inc r24
  rjmp .Lsniff_next
.Lsn_length:
  cpi r25, 2                         /* LENGTH < 2 is no packet */
  brlo .Lsniff_off
  lds r30, uart_sniff_sum
  add r30, r25
  sts uart_sniff_sum, r30
  mov r30, r25                       /* bytes before the checksum: instruction + parameters */
  dec r30
  sts uart_sniff_count, r30
  inc r24
  rjmp .Lsniff_next
.Lsniff_off:
  ldi r24, UART_SNIFF_OFF
.Lsniff_wake:
  sbi _SFR_IO_ADDR(GPIOR0), BOARD_WAKE_BIT /* the main loop takes the held bytes */
.Lsniff_next:
  sts uart_sniff, r24
.Lsn_keep:
  rjmp .Lstore

.Lsn_instruction:
  ldi r24, UART_SNIFF_BODY
  lds r30, uart_sniff_skip
  tst r30
  brne .Lsn_sum
  cpi r25, 8                         /* bit r25 of uart_sniff_mask */
  brsh .Lsniff_off
  sts uart_sniff_instruction, r25
  lds r30, uart_sniff_mask
  mov r31, r25
7:
  subi r31, 1
  brcs 8f
  lsr r30
  rjmp 7b
8:
  sbrs r30, 0
  rjmp .Lsniff_off
  ldi r24, UART_SNIFF_FIRST_PARAM
  rjmp .Lsn_sum
.Lsn_param:
  cpi r24, UART_SNIFF_FIRST_PARAM
  brne .Lsn_body
  lds r30, uart_sniff_instruction    /* a WRITE's start address: EEPROM area -> not streamed */
  cpi r30, DXL_INST_WRITE_ASM
  brne .Lsn_body
  cpi r25, UART_SNIFF_WRITE_MIN_ADDR
  brlo .Lsniff_off
.Lsn_body:
  ldi r24, UART_SNIFF_BODY
.Lsn_sum:                            /* r24 = the next state: sum the byte, count it down */
  lds r30, uart_sniff_sum
  add r30, r25
  sts uart_sniff_sum, r30
  lds r31, uart_sniff_count
  dec r31
  sts uart_sniff_count, r31
  brne .Lsniff_next
  ldi r24, UART_SNIFF_SKIP_CHECKSUM  /* only the checksum is to come */
  lds r31, uart_sniff_skip
  tst r31
  brne .Lsniff_next
  /* This servo's packet: arm. A PING armed at its instruction (LENGTH 2) answers with the
   * loaded ready reply; anything else streams from it its header FF FF ID and waits for
   * the main loop's uart_reply_publish(). */
  com r30
  sts uart_tx_checksum, r30
  lds r30, uart_sniff
  cpi r30, UART_SNIFF_INSTRUCTION
  brne 5f
  lds r30, uart_sniff_instruction
  cpi r30, DXL_INST_PING_ASM
  breq 6f
5:
  ldi r30, UART_STREAM_HEADER_BYTES
  sts uart_tx_published, r30
6:
  lds r30, uart_rx_head              /* the checksum will be the byte after this one */
  subi r30, -2
  sts uart_sniff_end, r30
  ldi r30, UART_REPLY_ARMED
  sts uart_tx_state, r30
  ldi r24, UART_SNIFF_ARMED
  rjmp .Lsniff_wake

/* The checksum of another servo's packet: when it is good, the whole packet is dropped by
 * moving the head back to the tail (the sniff starts with an empty ring, the main loop leaves
 * the ring alone while it runs, and each dropped packet empties it again, so the ring holds
 * exactly this packet), and the sniff waits for the next one; the main loop is not woken. */
.Lsn_skip_checksum:
  lds r30, uart_sniff_sum
  add r30, r25
  cpi r30, 0xFF
  brne 3f
  lds r30, uart_rx_tail              /* the ring holds this packet and nothing else */
  sts uart_rx_head, r30
  ldi r24, 0
  sts uart_sniff, r24
  rjmp .Ltick
3:
  rjmp .Lsniff_off

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
  lds r24, _SFR_MEM_ADDR(UCSR0A)     /* FE0/DOR0 describe the byte in UDR0: read it first */
  lds r25, _SFR_MEM_ADDR(UDR0)
  andi r24, _BV(FE0) | _BV(DOR0)
  brne .Lline_error
.Lclassify:
  lds r24, uart_tx_state             /* an armed reply first: it is the timed path */
  cpi r24, UART_REPLY_ARMED
  breq .Larmed
  push r30
  push r31
  lds r24, uart_sniff
  cpi r24, UART_SNIFF_ARMED
  brsh .Lstore_wake
  rjmp .Lsniff                       /* a sniff is under way (reply IDLE) */

.Lline_error:
  lds r24, uart_rx_line_error_count
  inc r24
  breq .Lclassify                    /* saturate at 255 */
  sts uart_rx_line_error_count, r24
  rjmp .Lclassify

/* ARMED: this byte is the checksum of the packet whose reply is loaded. Z is pushed only
 * after the UDR0 write on the Return Delay Time 0-1 path. */
.Larmed:
  lds r24, uart_tx_checksum
  cp r25, r24
  brne .Lmismatch
  lds r24, uart_tx_mode
  cpi r24, UART_START_NOW
  brne .Ldelayed
  sbi _SFR_IO_ADDR(PORTD), UART_BUS_DIR_BIT
  ldi r24, DXL_HEADER_BYTE_ASM        /* every status packet starts with it */
  sts _SFR_MEM_ADDR(UDR0), r24       /* the reply starts here */
  push r30
  push r31
  rcall uart_sending
  rjmp .Lstore_wake

.Lmismatch:
  push r30
  push r31
  ldi r24, UART_REPLY_IDLE           /* the main loop handles the packet as usual */
  sts uart_tx_state, r24
  rjmp .Lstore_wake

.Ldelayed:
  push r30
  push r31
  lds r30, uart_tx_delay_ticks
  lds r31, uart_tx_delay_ticks + 1
  add r30, r18
  adc r31, r19
  sbiw r30, UART_SPIN_COMPENSATION_TICKS /* Z = the tick at which to leave the spin */
  cpi r24, UART_START_TIMER
  breq .Ltimer
  rcall uart_spin_and_send

.Lstore_wake:
  sbi _SFR_IO_ADDR(GPIOR0), BOARD_WAKE_BIT /* a byte for the main loop */
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

.Ltimer:
  sts uart_tx_start_tick + 1, r31    /* TIMER1_COMPA spins until this tick */
  sts uart_tx_start_tick, r30
  sbiw r30, UART_COMPA_EARLY_TICKS
  sts _SFR_MEM_ADDR(OCR1AH), r31     /* 16-bit write: high byte first */
  sts _SFR_MEM_ADDR(OCR1AL), r30
  /* OCF1A may be stale (OCR1A matches every timer period): TIMER1_COMPA ignores it. */
  ldi r24, _BV(OCIE1A) | _BV(OCIE1B)
  sts _SFR_MEM_ADDR(TIMSK1), r24
  ldi r24, UART_REPLY_WAITING
  sts uart_tx_state, r24
  rjmp .Lstore_wake

/* TIMER1_COMPA: UART_COMPA_EARLY_TICKS before a WAITING reply's start tick. Spins to the exact
 * tick, starts the reply and switches COMPA off. An entry before that is a stale OCF1A from an
 * earlier match (OCR1A matches once every timer period), left set on purpose: clearing it by
 * writing TIFR1 also drops a pending OCF1B in simavr 1.6 (measured: the control tick then
 * stops for a whole timer period). Not nested in a 16-bit timer access: TIMER1_COMPB writes
 * OCR1B with interrupts off. */
  .section .text.uart_compa_isr, "ax", @progbits
  .global TIMER1_COMPA_vect
TIMER1_COMPA_vect:
  push r24
  in r24, _SFR_IO_ADDR(SREG)
  push r24
  push r25
  push r30
  push r31
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
  push r24
  in r24, _SFR_IO_ADDR(SREG)
  push r24
  push r25
  push r30
  push r31
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

/* Shared by USART_RX (Return Delay Time 2-6), TIMER1_COMPA and the main loop's late start
 * (uart.c): spins until TCNT1 reaches Z (the start tick less UART_SPIN_COMPENSATION_TICKS),
 * drives the bus and writes the reply's first byte; uart_sending then hands the rest to the
 * UDRE ISR. Interrupts off; clobbers r24. C entries (call-clobbered registers only):
 * uart_start_at(tick) = the spin from Z = tick, uart_send_first() = no spin. */
  .section .text.uart_spin_and_send, "ax", @progbits
  .global uart_start_at
uart_start_at:
  movw r30, r24
uart_spin_and_send:
  lds r24, _SFR_MEM_ADDR(TCNT1L)     /* 8 cycles a turn = 1 tick */
  cp r24, r30
  lds r24, _SFR_MEM_ADDR(TCNT1H)
  cpc r24, r31
  brmi uart_spin_and_send            /* while (int16_t)(TCNT1 - Z) < 0 */
  .global uart_send_first
uart_send_first:
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
