/* The USART_RX interrupt's fast paths (see uart.h). It runs the framing step of every byte on
 * the bus (core/dxl_frame.h: at 1 Mbps one every 160 cycles, heard by every servo), and its
 * entry times the replies; each path below is the step's work for one case of state and byte,
 * written out here because a figure of scripts/bench needs it (docs/firmware.md "The receive
 * interrupt"), and bytes of any other case go to uart_rx_frame_byte() (uart.c), which calls
 * dxl_frame_step() itself. Tested first to last:
 *
 * - ARMED (uart_tx_state): this byte is the checksum of the packet whose reply is armed:
 *     matches -> start the reply, by uart_tx_mode: NOW writes the first byte at once (set PD2,
 *       UDR0, receiver off, UDRE interrupt on); SPIN busy-waits until TCNT1 reaches start =
 *       tick + delay - UART_SPIN_COMPENSATION_TICKS, then as NOW (Return Delay Time 2..5: at
 *       most about 130 cycles of spinning); TIMER sets uart_tx_start_tick = start, OCR1A =
 *       start - UART_COMPA_EARLY_TICKS, and TIMER1_COMPA (uart_tx_isr.S) starts it;
 *     differs -> IDLE, and the byte ends the packet as below (the main loop answers it as
 *       usual: Checksum Error etc.).
 *   The reply at Return Delay Time 0.
 * - SKIP (uart_rx_skip_count > 0): a byte of a packet the servo does not keep (the step's BODY
 *   of another servo's packet, after its LENGTH): counted down and forgotten. The host cost of
 *   a shared bus, where most bytes are other servos'.
 * - BODY of a packet the servo keeps: summed, counted down, appended to the ring; at the last
 *   byte but one of a packet for this servo (UART_RX_ARM) the reply is armed when the
 *   instruction is one the link listens for; at the checksum the frame is back at SEARCH, the
 *   tick noted and the main loop woken (UART_RX_EACH: at every byte). The reply at Return Delay
 *   Time 0 (the arming), and the host cost of a broadcast SYNC_WRITE.
 * - SEARCH, SECOND_FF, ID: a header's 0xFF and its ID (a byte that cannot be one is dropped).
 *   The host cost: every servo reads the header of every packet.
 * - LENGTH (>= 2) of another servo's packet while listening: its LENGTH bytes are skipped.
 * - anything else (the LENGTH of a packet the servo keeps, a LENGTH below 2, a Protocol 2.0
 *   frame's bytes): uart_rx_frame_byte().
 * A frame error / data overrun flagged for the byte is counted in every state.
 *
 * The tick (uart_rx_tick, for the main loop's late replies) is TCNT1 normalised to one reference
 * moment after the interrupt (uart.h): the paths that note it subtract the whole ticks they read
 * late (*_READ_LATE_TICKS). Registers: r24 (kept in GPIOR1, SREG in GPIOR2: 1 cycle each, not
 * 2; only this ISR uses them, and it never nests in itself), r25 the byte, Z. r1 is not assumed
 * to be 0. Cycle counts: docs/firmware.md. */
#include <avr/io.h>
#include "board.h"
#include "dxl_frame.h"
#include "uart.h"

#if UART_REPLY_ARMED != UART_RX_ARMED_HELD
#error "the arming stores one register into both"
#endif

#if defined(__AVR_HAVE_JMP_CALL__)
#define XCALL call
#else
#define XCALL rcall
#endif

/* Whole Timer1 ticks (8 cycles) by which a path reads TCNT1 after the reference moment (6
 * cycles after the vector is entered), counted from the code below and rounded down, so a late
 * reply is never early: a kept packet's checksum 57 cycles (63 when it was an armed checksum
 * that differs). */
#define END_READ_LATE_TICKS 7

/* Z = &uart_rx_ring[index & UART_RX_RING_MASK] (index: a register; Z may be it). */
.macro RING_SLOT_Z index
  mov r30, \index
  andi r30, UART_RX_RING_MASK
  ldi r31, 0
  subi r30, lo8(-(uart_rx_ring))
  sbci r31, hi8(-(uart_rx_ring))
.endm

/* The receiver's progress (uart.h), one block. */
  .section .bss.uart_rx_progress, "aw", @nobits
  .global uart_rx_progress, uart_rx_frame, uart_rx_skip_count, uart_rx_headers
  .type uart_rx_progress, @object
  .size uart_rx_progress, UART_RX_PROGRESS_BYTES
uart_rx_progress:
uart_rx_skip_count:
  .skip 1
uart_rx_headers:
  .skip 1
uart_rx_frame:
  .skip DXL_FRAME_BYTES
#if UART_RX_OFS_SKIP_COUNT != 0 || UART_RX_OFS_HEADERS != 1 || UART_RX_OFS_FRAME != 2
#error "uart.h's offsets are this block's"
#endif

  .section .text.uart_rx_isr, "ax", @progbits

/* The paths are placed around the vector for the branch range: the armed checksum and the skip
 * before it, the header and the body after it. */

/* A byte the USART flagged (frame error /
 * data overrun): counted, saturating at 255. Clobbers r24. */
.Lcount_line_error:
  lds r24, uart_rx_line_error_count
  inc r24
  breq 1f
  sts uart_rx_line_error_count, r24
1:
  ret

/* The reply is under way: the checksum ends the packet in the ring (it has room: the packet was
 * held from an empty ring), and the main loop commits it. */
.Larmed_done:
  lds r24, uart_rx_head
  RING_SLOT_Z r24
  st Z, r25
  inc r24
  sts uart_rx_head, r24
  ldi r24, DXL_FRAME_SEARCH
  sts uart_rx_frame + DXL_FRAME_OFS_STATE, r24
  sts uart_rx_frame + DXL_FRAME_OFS_LEFT, r24
  sbi _SFR_IO_ADDR(GPIOR0), BOARD_WAKE_BIT
  rjmp .Lexit

/* ARMED with a Return Delay Time of 2 or more (SPIN, TIMER). */
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
  XCALL uart_spin_and_send
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

/* ARMED: this byte is the checksum of the packet whose reply is loaded. Z is pushed only after
 * the UDR0 write on the Return Delay Time 0-1 path. */
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
  ldi r24, DXL_HEADER_BYTE_ASM       /* every status packet starts with it */
  sts _SFR_MEM_ADDR(UDR0), r24       /* the reply starts here */
  push r30
  push r31
  XCALL uart_sending
  rjmp .Larmed_done
.Larmed_line_error:
  rcall .Lcount_line_error
  rjmp .Larmed_compare

.Lmismatch:                          /* the main loop answers the packet as usual */
  ldi r24, UART_REPLY_IDLE
  sts uart_tx_state, r24
  rjmp .Lhold

/* SKIP: r24 = the count after this byte. */
.Lskip:
  sts uart_rx_skip_count, r24
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

  .global USART_RX_vect
USART_RX_vect:
  out _SFR_IO_ADDR(GPIOR1), r24
  in r24, _SFR_IO_ADDR(SREG)
  out _SFR_IO_ADDR(GPIOR2), r24
  lds r24, uart_tx_state             /* an armed reply first: it is the timed path */
  cpi r24, UART_REPLY_ARMED
  breq .Larmed
  lds r24, uart_rx_skip_count        /* then a byte to skip: r24 only */
  subi r24, 1
  brcc .Lskip
  push r25
  lds r24, _SFR_MEM_ADDR(UCSR0A)     /* FE0/DOR0 describe the byte in UDR0: read it first */
  lds r25, _SFR_MEM_ADDR(UDR0)
  andi r24, _BV(FE0) | _BV(DOR0)
  brne .Lline_error
.Lclassify:
  lds r24, uart_rx_frame + DXL_FRAME_OFS_STATE
  cpi r24, DXL_FRAME_BODY
  breq .Lhold
  brsh .Lprotocol2
  cpi r24, DXL_FRAME_ID
  breq .Lh_id
  brlo .Lh_ff
  rjmp .Lh_length
.Lprotocol2:                         /* a Protocol 2.0 frame's byte */
  rjmp .Lslow

/* SEARCH (r24 = 0) and SECOND_FF (1): an 0xFF moves on (a header begun is counted for the gap
 * rule, uart.c), anything else is garbage and the search goes on. Only r24 and r25. */
.Lh_ff:
  cpi r25, DXL_HEADER_BYTE_ASM
  brne .Lh_search
  tst r24
  brne .Lh_next
  lds r25, uart_rx_headers
  inc r25
  sts uart_rx_headers, r25
.Lh_next:
  inc r24
  rjmp .Lh_set
.Lh_search:
  ldi r24, DXL_FRAME_SEARCH
.Lh_set:
  sts uart_rx_frame + DXL_FRAME_OFS_STATE, r24
.Lh_exit:                            /* only r25 pushed */
  pop r25
  in r24, _SFR_IO_ADDR(GPIOR2)
  out _SFR_IO_ADDR(SREG), r24
  in r24, _SFR_IO_ADDR(GPIOR1)
  reti

/* ID: the ID, with the sum started; a further 0xFF is still the header (counted). */
.Lh_id:
  cpi r25, DXL_HEADER_BYTE_ASM
  breq .Lh_further_ff
  sts uart_rx_frame + DXL_FRAME_OFS_ID, r25
  sts uart_rx_frame + DXL_FRAME_OFS_SUM, r25
  ldi r24, DXL_FRAME_LENGTH
  rjmp .Lh_set
.Lh_further_ff:
  lds r25, uart_rx_headers
  inc r25
  sts uart_rx_headers, r25
  rjmp .Lh_exit

.Lline_error:
  rcall .Lcount_line_error
  rjmp .Lclassify

/* BODY of a packet the servo keeps (r25 = the byte). */
.Lhold:
  push r30
  push r31
  lds r24, uart_rx_frame + DXL_FRAME_OFS_SUM
  add r24, r25
  sts uart_rx_frame + DXL_FRAME_OFS_SUM, r24
  lds r24, uart_rx_head
  lds r30, uart_rx_tail
  mov r31, r24
  sub r31, r30                       /* bytes in the ring */
  cpi r31, UART_RX_RING_BYTES
  brsh .Lfull
  RING_SLOT_Z r24
  st Z, r25
  inc r24
  sts uart_rx_head, r24              /* publish the byte after it is stored */
.Lcount:
  lds r24, uart_rx_frame + DXL_FRAME_OFS_LEFT
  dec r24
  sts uart_rx_frame + DXL_FRAME_OFS_LEFT, r24
  breq .Lend
  lds r30, uart_rx_mode
  cpi r24, 1
  breq .Lbefore_checksum
.Lwake_if_each:
  sbrc r30, UART_RX_EACH_BIT
  sbi _SFR_IO_ADDR(GPIOR0), BOARD_WAKE_BIT
.Lexit:
  pop r31
  pop r30
  pop r25
  in r24, _SFR_IO_ADDR(GPIOR2)
  out _SFR_IO_ADDR(SREG), r24
  in r24, _SFR_IO_ADDR(GPIOR1)
  reti

.Lfull:
  lds r24, uart_rx_dropped_count
  inc r24
  breq .Lcount                       /* saturate at 255 */
  sts uart_rx_dropped_count, r24
  rjmp .Lcount

/* The checksum (r24 = 0 = DXL_FRAME_SEARCH): the packet is complete. */
.Lend:
  sts uart_rx_frame + DXL_FRAME_OFS_STATE, r24
  ldi r24, END_READ_LATE_TICKS
  lds r30, _SFR_MEM_ADDR(TCNT1L)
  lds r31, _SFR_MEM_ADDR(TCNT1H)
  sub r30, r24
  sbci r31, 0
  sts uart_rx_tick + 1, r31
  sts uart_rx_tick, r30
  sbi _SFR_IO_ADDR(GPIOR0), BOARD_WAKE_BIT /* a packet for the main loop */
  rjmp .Lexit

/* The last byte but one (r30 = the mode): for this servo's packet, arm the reply if its
 * instruction's bit is set in uart_listen_mask (instructions 0..7), and a WRITE with parameters
 * starts past the ID and the Baud Rate (UART_ARM_WRITE_MIN_ADDR). A PING (LENGTH 2) answers
 * with the loaded reply; anything else streams its header FF FF ID and waits for the main loop's
 * uart_reply_publish(). */
.Lbefore_checksum:
  cpi r30, UART_RX_ARM
  brne .Lwake_if_each
  lds r24, uart_rx_ring + UART_PACKET_OFS_INSTRUCTION /* (from index 0: uart.h) */
  cpi r24, 8
  brsh .Larm_none
  lds r25, uart_listen_mask
  mov r31, r24
1:
  subi r31, 1                        /* r25 >>= the instruction */
  brcs 2f
  lsr r25
  rjmp 1b
2:
  sbrs r25, 0
  rjmp .Larm_none
  lds r25, uart_rx_frame + DXL_FRAME_OFS_LENGTH
  cpi r24, DXL_INST_WRITE_ASM
  brne 3f
  cpi r25, 3
  brlo 4f                            /* a WRITE without parameters: armed (an Instruction Error) */
  lds r30, uart_rx_ring + UART_PACKET_OFS_FIRST_PARAM
  cpi r30, UART_ARM_WRITE_MIN_ADDR
  brlo .Larm_none
3:
  cpi r25, 2
  brne 4f
  cpi r24, DXL_INST_PING_ASM
  breq 5f
4:
  ldi r25, UART_STREAM_HEADER_BYTES
  sts uart_tx_published, r25
5:
  lds r25, uart_rx_frame + DXL_FRAME_OFS_SUM
  com r25
  sts uart_tx_checksum, r25
  lds r25, uart_rx_head              /* the checksum will be at the head: the packet ends after it */
  inc r25
  sts uart_rx_armed_end, r25
  ldi r25, UART_REPLY_ARMED           /* = UART_RX_ARMED_HELD */
  sts uart_rx_armed, r25
  sts uart_tx_state, r25
  sbi _SFR_IO_ADDR(GPIOR0), BOARD_WAKE_BIT /* the main loop prepares the reply */
.Larm_none:
  rjmp .Lexit

/* LENGTH: below 2 it is the step's (a Protocol 2.0 header, or no packet), and so is any packet
 * while not listening (kept: uart_rx_frame_byte puts its header into the ring). While
 * listening, from 2 on, another servo's packet (not this servo's ID, not broadcast) is skipped:
 * its LENGTH bytes are passed over and the search goes on after them; this servo's or a
 * broadcast packet is kept, and the listening ends: the frame goes to BODY with LENGTH bytes to
 * come (its sum with the LENGTH), its header FF FF ID LENGTH into the ring from index 0 (empty
 * and at 0 while listening: uart.h), its mode HOLD, or ARM for this servo's ID, up to
 * UART_HOLD_MAX_LENGTH, else EACH. */
.Lh_length:
  cpi r25, 2
  brlo .Lh_step
  lds r24, uart_listening             /* the ID listened for + 1; 0: not listening */
  subi r24, 1
  brcs .Lh_step
  sts uart_rx_skip_count, r25        /* taken back below when kept: it frees r25 */
  lds r25, uart_rx_frame + DXL_FRAME_OFS_ID
  cp r24, r25
  breq .Lh_keep
  cpi r25, DXL_ID_BROADCAST_ASM
  breq .Lh_keep
  ldi r24, DXL_FRAME_SEARCH
  rjmp .Lh_set
.Lh_step:
  rjmp .Lslow
.Lh_keep:                            /* r24 = the ID listened for, r25 = the ID */
  sts uart_rx_ring + 2, r25
  push r30
  ldi r30, UART_RX_HOLD
  cpse r24, r25
  rjmp 1f
  ldi r30, UART_RX_ARM
1:
  lds r25, uart_rx_skip_count        /* the LENGTH */
  sts uart_rx_ring + 3, r25
  cpi r25, UART_HOLD_MAX_LENGTH + 1
  brlo 2f
  ldi r30, UART_RX_EACH
  sbi _SFR_IO_ADDR(GPIOR0), BOARD_WAKE_BIT
2:
  sts uart_rx_mode, r30
  ldi r24, 0                         /* the next packets wait for the main loop */
  sts uart_listening, r24
  sts uart_rx_frame + DXL_FRAME_OFS_LENGTH, r25
  sts uart_rx_frame + DXL_FRAME_OFS_LEFT, r25
  lds r30, uart_rx_frame + DXL_FRAME_OFS_SUM
  add r30, r25
  sts uart_rx_frame + DXL_FRAME_OFS_SUM, r30
  ldi r30, 0
  sts uart_rx_skip_count, r30
  ldi r24, DXL_HEADER_BYTE_ASM
  sts uart_rx_ring + 0, r24
  sts uart_rx_ring + 1, r24
  ldi r30, UART_PACKET_HEADER_BYTES
  sts uart_rx_head, r30              /* publish the header after it is stored */
  ldi r30, DXL_FRAME_BODY
  sts uart_rx_frame + DXL_FRAME_OFS_STATE, r30
  pop r30
  rjmp .Lh_exit

/* The slow path: the byte (r25) through the framing step in C. r24 and SREG are in GPIOR1/2,
 * r25 is pushed; the call-clobbered registers C may use are saved here. */
.Lslow:
  push r0
  push r1
  push r18
  push r19
  push r20
  push r21
  push r22
  push r23
  push r26
  push r27
  push r30
  push r31
  clr r1
  mov r24, r25
  XCALL uart_rx_frame_byte
  pop r31
  pop r30
  pop r27
  pop r26
  pop r23
  pop r22
  pop r21
  pop r20
  pop r19
  pop r18
  pop r1
  pop r0
  rjmp .Lh_exit

