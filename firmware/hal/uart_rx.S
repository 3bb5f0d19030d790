/* USART_RX ISR (see uart.h). Assembly because it runs for every byte on the bus (at 1 Mbps
 * one every 160 cycles, heard by every servo) and is on the measured reply path: every cycle
 * before the UDR0 write adds to the reply latency at Return Delay Time 0.
 *
 * Every byte, by state:
 * - ARMED (tested first: the timed path): this byte is the checksum of the packet whose reply
 *   is armed (by the sniff below):
 *     differs -> IDLE (the main loop handles the packet as usual: Checksum Error etc.);
 *     matches -> start the reply, by uart_tx_mode:
 *       NOW    write the first byte at once (set PD2, UDR0, receiver off, UDRE interrupt on);
 *       SPIN   busy-wait until TCNT1 reaches start = tick + delay - UART_SPIN_COMPENSATION_TICKS,
 *              then as NOW (Return Delay Time 2..5: at most about 130 cycles of spinning);
 *       TIMER  uart_tx_start_tick = start, OCR1A = start - UART_COMPA_EARLY_TICKS;
 *              TIMER1_COMPA spins from there to start, then as NOW.
 * - SKIP (uart_skip_count > 0, tested second): a byte of another servo's packet, after its
 *   LENGTH: read, counted down and forgotten, in 34 cycles with the interrupt's response and
 *   vector jump (ATmega88).
 * - the sniff (uart_sniff 0..UART_SNIFF_CHECKSUM, started by the main loop with the ring and
 *   the finder empty; uart.h): reads the header FF FF ID LENGTH in r24/r25 alone, holding it
 *   in its state (HEADER below, 50 to 60 cycles a byte with the interrupt's response and
 *   vector jump), then frames and sums INSTRUCTION PARAMS CHECKSUM as they arrive (about 85
 *   cycles a byte) and holds them in the ring without waking the main loop. Its fate,
 *   decided at the ID and the instruction (UART_FATE_*):
 *     ARM        this servo's, instruction in uart_sniff_mask (and a WRITE's start address
 *                past the EEPROM area): at the last byte before the checksum the reply is
 *                ARMED as above, so neither the main loop's latency nor its long passes (the
 *                control tick) delay it. A PING (LENGTH 2) starts the loaded ready reply; any
 *                other packet streams the loaded reply's header FF FF ID, and the UDRE ISR
 *                waits for the main loop to publish the rest;
 *     DROP       another servo's (docs/policy.md "Framing and bus": parsed to its end by its
 *                LENGTH and ignored): at its LENGTH the LENGTH bytes still to come are
 *                skipped (SKIP above) and the sniff waits for the next packet's header; its
 *                header never reaches the ring;
 *     HAND_OVER  broadcast, or this servo's and not armed: at its checksum the sniff ends
 *                and the main loop takes the whole packet in one pass.
 *   A packet the servo keeps gets its header FF FF ID into the ring at its LENGTH. A LENGTH
 *   over UART_SNIFF_MAX_LENGTH ends the sniff there (UART_SNIFF_OFF), and so does the
 *   checksum of a HAND_OVER packet.
 * - OFF (the finder's): append to the ring (or count it dropped when full), note the tick,
 *   wake the main loop.
 * A frame error / data overrun flagged for the byte is counted in every state.
 *
 * The tick (uart_rx_tick, for the main loop's late replies) is TCNT1 normalised to one
 * reference moment after the interrupt (uart.h): each path reads TCNT1 where it needs it and
 * subtracts the whole ticks it reads late (*_READ_LATE_TICKS), so a byte the sniff holds
 * costs neither the read nor its registers. Registers: r24 scratch / the sniff's
 * state, r25 the byte, Z. r1 is not assumed to be 0. Cycle counts: docs/firmware.md.
 */
#include <avr/io.h>
#include "board.h"
#include "uart.h"

/* Whole Timer1 ticks (8 cycles) by which each path reads TCNT1 after the reference moment
 * (uart.h: 6 cycles after the vector is entered), counted from the code below and rounded
 * down, so a late reply is never early: the finder's byte 30 cycles (its path tests the armed
 * state, the skip count and the header states first), an armed checksum that differs 27, the
 * byte that ends the sniff (from its checksum state) 40 (sim_servo's ACTION at Return Delay
 * Time 250 and 254 measures it: +0.00..+0.50 us, never early). */
#define OFF_READ_LATE_TICKS 3
#define MISMATCH_READ_LATE_TICKS 3
#define HAND_OVER_READ_LATE_TICKS 5

/* Z = &uart_rx_ring[index & UART_RX_RING_MASK] (index: a register; Z may be it). */
.macro RING_SLOT_Z index
  mov r30, \index
  andi r30, UART_RX_RING_MASK
  ldi r31, 0
  subi r30, lo8(-(uart_rx_ring))
  sbci r31, hi8(-(uart_rx_ring))
.endm

  .section .text.uart_rx_isr, "ax", @progbits
/* (Placed before the vector for the branch range.) The sniff past the header: r24 =
 * uart_sniff (its state before this byte, UART_SNIFF_INSTRUCTION..UART_SNIFF_CHECKSUM), r25
 * = the byte; Z saved. Each state either moves on (and holds the byte), or ends the sniff. */
/* The checksum of a packet framed and not armed (HAND_OVER): the whole packet is the
 * finder's. */
.Lsn_checksum:
.Lsniff_off:                         /* the held bytes and this one are the finder's */
  ldi r24, UART_SNIFF_OFF
  sts uart_sniff, r24
  ldi r24, HAND_OVER_READ_LATE_TICKS
  rjmp .Lstamp

/* (Placed here for the branch range.) LENGTH 0 or 1 cannot start a 1.0 packet. After the ID
 * 0xFD, LENGTH 0 starts a Protocol 2.0 frame (FF FF FD 00 ID LEN_L LEN_H ...): the sniff ends
 * and the frame is the finder's, which skips it whole by its 16-bit length (docs/policy.md
 * "Framing and bus"); the sniff stays off until the finder is done with it. Anything else is
 * dropped and the sniff waits for the next FF. r25 = 0 here. */
.Lh_protocol2:
  lds r24, uart_sniff_sum            /* the ID */
  cpi r24, DXL_PROTOCOL2_ID_ASM
  brne .Lh_protocol2_not
  push r30
  push r31
  ldi r24, DXL_HEADER_BYTE_ASM
  rcall .Lring_put
  rcall .Lring_put
  ldi r24, DXL_PROTOCOL2_ID_ASM
  rcall .Lring_put
  rjmp .Lsniff_off                   /* and this byte, the 00 */
.Lh_protocol2_not:
  rjmp .Lh_restart

/* Appends r24 to the ring (it has room: the sniff holds at most UART_SNIFF_MAX_HELD
 * bytes); Z clobbered. The head is published before the store: the main loop leaves the
 * ring alone while the sniff runs, and this runs with interrupts off. */
.Lring_put:
  lds r31, uart_rx_head
  inc r31
  sts uart_rx_head, r31
  dec r31
  RING_SLOT_Z r31
  st Z, r24
  ret

/* The LENGTH of a packet this servo keeps (ARM, HAND_OVER; LENGTH >= 2): the header the
 * sniff framed without storing goes into the ring first, as FF FF ID (further FFs before
 * the ID are a header to the finder too, which frames the same packet without them). */
.Lsn_length:
  ldi r24, DXL_HEADER_BYTE_ASM
  rcall .Lring_put
  rcall .Lring_put
  lds r24, uart_sniff_sum            /* the ID */
  rcall .Lring_put
  cpi r25, UART_SNIFF_MAX_LENGTH + 1 /* longer: the finder's, so the ring cannot fill */
  brsh .Lsniff_off
  sts uart_sniff_count, r25          /* .Lsn_sum counts this byte down: LENGTH - 1 are left
                                        before the checksum (instruction and parameters) */
  ldi r24, UART_SNIFF_INSTRUCTION
  rjmp .Lsn_sum

.Lsniff:
  cpi r24, UART_SNIFF_BODY           /* the most frequent first; r24 is the next state too */
  breq .Lsn_sum
  brsh .Lsn_checksum
  cpi r24, UART_SNIFF_FIRST_PARAM
  breq .Lsn_first_param
.Lsn_instruction:
  ldi r24, UART_SNIFF_BODY
  lds r30, uart_sniff_fate
  cpi r30, UART_FATE_ARM
  brne .Lsn_sum                      /* framed only */
  sts uart_sniff_instruction, r25
  cpi r25, 8                         /* bit r25 of uart_sniff_mask */
  brsh .Lsn_hand_over
  lds r30, uart_sniff_mask
  mov r31, r25
7:
  subi r31, 1
  brcs 8f
  lsr r30
  rjmp 7b
8:
  ldi r24, UART_SNIFF_FIRST_PARAM
  sbrc r30, 0
  rjmp .Lsn_sum
.Lsn_hand_over:                      /* this servo's, not armed: the finder's at its end */
  ldi r30, UART_FATE_HAND_OVER
  sts uart_sniff_fate, r30
  ldi r24, UART_SNIFF_BODY
  rjmp .Lsn_sum
.Lsn_first_param:
  lds r30, uart_sniff_instruction    /* a WRITE's start address: ID or baud -> not armed */
  cpi r30, DXL_INST_WRITE_ASM
  brne .Lsn_body
  cpi r25, UART_SNIFF_WRITE_MIN_ADDR
  brlo .Lsn_hand_over
.Lsn_body:
  ldi r24, UART_SNIFF_BODY
.Lsn_sum:                            /* r24 = the next state: sum the byte, count it down */
  lds r30, uart_sniff_sum
  add r30, r25
  sts uart_sniff_sum, r30
  lds r31, uart_sniff_count
  dec r31
  sts uart_sniff_count, r31
  brne .Lsn_set
  ldi r24, UART_SNIFF_CHECKSUM       /* only the checksum is to come */
  lds r31, uart_sniff_fate
  cpi r31, UART_FATE_ARM
  brne .Lsn_set
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
  sbi _SFR_IO_ADDR(GPIOR0), BOARD_WAKE_BIT /* the main loop prepares the reply */
.Lsn_set:
  sts uart_sniff, r24
.Lsn_hold:                           /* held: the LENGTH bound keeps the ring from filling */
  lds r24, uart_rx_head
.Lstore_at_head:                     /* r24 = uart_rx_head, the ring has room */
  RING_SLOT_Z r24
  st Z, r25
  inc r24
  sts uart_rx_head, r24              /* publish the byte after it is stored */
  rjmp .Lexit


/* A byte the USART flagged (frame error / data overrun): counted, saturating at 255.
 * Clobbers r24. */
.Lcount_line_error:
  lds r24, uart_rx_line_error_count
  inc r24
  breq 1f
  sts uart_rx_line_error_count, r24
1:
  ret

/* SKIP: r24 = the count after this byte. */
.Lskip:
  sts uart_skip_count, r24
  lds r24, _SFR_MEM_ADDR(UCSR0A)
  andi r24, _BV(FE0) | _BV(DOR0)
  breq .Lskip_read
  rcall .Lcount_line_error
.Lskip_read:
  lds r24, _SFR_MEM_ADDR(UDR0)       /* read and forgotten */
  in r24, _SFR_IO_ADDR(GPIOR2)
  out _SFR_IO_ADDR(SREG), r24
  in r24, _SFR_IO_ADDR(GPIOR1)
  reti

/* HEADER: the sniff frames FF FF ID LENGTH without storing them (r24 = the state, r25 = the
 * byte; only r25 saved), as the finder would read them: a byte that cannot start or go on
 * with a header is dropped and the sniff waits for the next FF; a further FF before the ID
 * is still the header. At the LENGTH, another servo's packet is skipped from there on, a
 * LENGTH < 2 is no packet, and a packet this servo keeps gets its header into the ring
 * (.Lsn_length). */
.Lh_ff:                              /* 0, 1: FF FF */
  cpi r25, DXL_HEADER_BYTE_ASM
  brne .Lh_restart
  inc r24
  rjmp .Lh_set
.Lh_id:
  cpi r25, DXL_HEADER_BYTE_ASM       /* (r24 = this state: unchanged) */
  breq .Lh_set
  sts uart_sniff_sum, r25
  cpi r25, DXL_ID_BROADCAST_ASM
  ldi r24, UART_FATE_HAND_OVER       /* broadcast: acted on by every servo, the finder's */
  breq 1f
  lds r24, uart_sniff_id
  cp r24, r25
  ldi r24, UART_FATE_ARM
  breq 1f
  ldi r24, UART_FATE_DROP            /* another servo's */
1:
  sts uart_sniff_fate, r24
  ldi r24, UART_SNIFF_LENGTH
  rjmp .Lh_set
.Lh_length:
  cpi r25, 2
  brlo .Lh_no_length
  lds r24, uart_sniff_fate
  cpi r24, UART_FATE_DROP
  brne .Lh_keep
  sts uart_skip_count, r25           /* the main loop is not woken */
.Lh_restart:
  ldi r24, 0
.Lh_set:
  sts uart_sniff, r24
  rjmp .Lh_exit
.Lh_keep:
  push r30
  push r31
  rjmp .Lsn_length
.Lh_no_length:                       /* LENGTH 0 or 1 (.Lh_protocol2) */
  tst r25
  brne .Lh_restart
  rjmp .Lh_protocol2


  .global USART_RX_vect
USART_RX_vect:
  out _SFR_IO_ADDR(GPIOR1), r24      /* r24 and SREG kept in GPIOR1/2 (1 cycle, not 2): only */
  in r24, _SFR_IO_ADDR(SREG)         /* this ISR uses them, and it never nests in itself */
  out _SFR_IO_ADDR(GPIOR2), r24
  lds r24, uart_tx_state             /* an armed reply first: it is the timed path */
  cpi r24, UART_REPLY_ARMED
  breq .Larmed
  lds r24, uart_skip_count           /* then a byte to skip: r24 only */
  subi r24, 1
  brcc .Lskip
  push r25
  lds r24, _SFR_MEM_ADDR(UCSR0A)     /* FE0/DOR0 describe the byte in UDR0: read it first */
  lds r25, _SFR_MEM_ADDR(UDR0)
  andi r24, _BV(FE0) | _BV(DOR0)
  brne .Lline_error
.Lclassify:
  lds r24, uart_sniff
  cpi r24, UART_SNIFF_ID             /* the header: r24 and r25 only (HEADER below) */
  breq .Lh_id
  brlo .Lh_ff
  cpi r24, UART_SNIFF_LENGTH
  breq .Lh_length
  push r30
  push r31
  cpi r24, UART_SNIFF_ARMED
  brsh 1f
  rjmp .Lsniff                       /* a sniff is under way (reply IDLE) */
1:
  ldi r24, OFF_READ_LATE_TICKS
/* r24 = ticks this path reads TCNT1 late: note the tick, store the byte, wake the main loop. */
.Lstamp:
  lds r30, _SFR_MEM_ADDR(TCNT1L)
  lds r31, _SFR_MEM_ADDR(TCNT1H)
  sub r30, r24
  sbci r31, 0
  sts uart_rx_tick + 1, r31
  sts uart_rx_tick, r30
  sbi _SFR_IO_ADDR(GPIOR0), BOARD_WAKE_BIT /* a byte for the main loop */
  lds r24, uart_rx_head
  lds r30, uart_rx_tail
  mov r31, r24
  sub r31, r30                       /* bytes in the ring */
  cpi r31, UART_RX_RING_BYTES
  brsh 1f
  rjmp .Lstore_at_head
1:
  lds r24, uart_rx_dropped_count     /* full */
  inc r24
  breq .Lexit                        /* saturate at 255 */
  sts uart_rx_dropped_count, r24
.Lexit:
  pop r31
  pop r30
.Lh_exit:                            /* the header's (only r25 pushed) */
  pop r25
  in r24, _SFR_IO_ADDR(GPIOR2)
  out _SFR_IO_ADDR(SREG), r24
  in r24, _SFR_IO_ADDR(GPIOR1)
  reti

.Lline_error:
  rcall .Lcount_line_error
  rjmp .Lclassify

/* ARMED: this byte is the checksum of the packet whose reply is loaded. Z is pushed only
 * after the UDR0 write on the Return Delay Time 0-1 path. */
.Larmed:
  push r25
  lds r24, _SFR_MEM_ADDR(UCSR0A)
  lds r25, _SFR_MEM_ADDR(UDR0)
  andi r24, _BV(FE0) | _BV(DOR0)
  brne .Larmed_line_error
.Larmed_compare:
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
.Larmed_done:                        /* the reply is under way: the main loop commits it */
  sbi _SFR_IO_ADDR(GPIOR0), BOARD_WAKE_BIT
  rjmp .Lsn_hold                     /* the ring has room: it held the packet's other bytes */

.Larmed_line_error:
  rcall .Lcount_line_error
  rjmp .Larmed_compare

.Lmismatch:
  push r30
  push r31
  ldi r24, UART_REPLY_IDLE           /* the main loop handles the packet as usual */
  sts uart_tx_state, r24
  ldi r24, MISMATCH_READ_LATE_TICKS
  rjmp .Lstamp

.Ldelayed:
  push r30
  push r31
  lds r30, _SFR_MEM_ADDR(TCNT1L)
  lds r31, _SFR_MEM_ADDR(TCNT1H)
  sbiw r30, UART_SPIN_COMPENSATION_TICKS + UART_ARMED_READ_LATE_TICKS
  lds r24, uart_tx_delay_ticks
  add r30, r24
  lds r24, uart_tx_delay_ticks + 1
  adc r31, r24                       /* Z = the tick at which to leave the spin */
  lds r24, uart_tx_mode
  cpi r24, UART_START_TIMER
  breq .Ltimer
  rcall uart_spin_and_send
  rjmp .Larmed_done

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
  rjmp .Larmed_done

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

/* Shared by USART_RX (Return Delay Time 2-6), TIMER1_COMPA and the main loop's late start
 * (uart.c): spins until TCNT1 reaches Z (the start tick less UART_SPIN_COMPENSATION_TICKS),
 * drives the bus and writes the reply's first byte; uart_sending then hands the rest to the
 * UDRE ISR. Interrupts off; clobbers r24. C entry (call-clobbered registers only):
 * uart_start_at(tick) = the spin from Z = tick. */
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
