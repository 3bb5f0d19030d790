/* Half-duplex Dynamixel bus on USART0 (docs/hardware.md "UART", "Pins"): the receiver, which
 * frames every byte by the one rule (core/dxl_frame.h), and one reply at a time. The link
 * layer reaches it through hal/link_port.c (link/dxl_link_port.h says what each function
 * promises); main.c initialises it.
 *
 * Receive: the USART_RX interrupt runs the framing step on every byte. Its hot paths are
 * assembly (uart_rx_fast.S: an armed reply's checksum, the skip of a packet this servo does
 * not keep, the body of one it keeps, and the header bytes); everything else goes through
 * uart_rx_frame_byte() (uart.c), which calls dxl_frame_step(). The packets the servo keeps go
 * into a single-producer single-consumer ring as FF FF ID LENGTH and their LENGTH bytes: the
 * RX interrupt is the only writer of uart_rx_head, the main loop the only writer of
 * uart_rx_tail; both are 8-bit and free-running (the ring index is the low bits), so each is
 * read and written in one instruction and never torn; the ring is full when head - tail ==
 * UART_RX_RING_BYTES (a byte that finds it full is counted in uart_rx_dropped_count).
 *
 * Transmit (uart_tx_isr.S, and USART_TX in uart.c): one status packet at a time, from a buffer
 * the caller keeps unchanged until the reply is DONE. PD2 (bus direction) is high and the
 * receiver is off (RXEN0 = 0: no own echo) from the first byte until TX-complete of the last.
 *
 * Reply timing (docs/policy.md "Replies"): the first byte is written to UDR0 2 us x Return
 * Delay Time after the RX interrupt of the packet's last byte. Two ways to start it:
 *   - armed: while listening, the RX interrupt arms the loaded reply at the last byte but one
 *     of a packet for this servo, with the checksum that completes it, and starts it the moment
 *     that byte arrives and matches (RDT 0-1: writes UDR0 itself; short delays: spins on
 *     TCNT1; longer: sets OCR1A and TIMER1_COMPA starts it);
 *   - late: uart_reply_send, after the main loop has handled the packet: at the tick of its
 *     last byte + the delay if that moment is still ahead, at once otherwise.
 *
 * This header is also included by the assembly: the constants it shares are plain #defines,
 * the C declarations sit under !__ASSEMBLER__. */
#ifndef HAL_UART_H
#define HAL_UART_H

#include <avr/io.h>

#include "dxl_frame.h"

/* Ring size: a power of two, <= 128 (8-bit free-running indices). While listening it is empty
 * with both indices at 0 (uart_listen), so the packet kept then, which the RX interrupt may hold
 * without waking the main loop (UART_HOLD_MAX_LENGTH) and arm, lies at fixed places from index
 * 0; it also holds the bytes that arrive while the main loop is busy with something else. */
#define UART_RX_RING_BYTES 128
#define UART_RX_RING_MASK (UART_RX_RING_BYTES - 1)

/* uart_rx_progress: these, then the receiver's dxl_frame_t. Its first UART_RX_MOVING_BYTES
 * (the skip count, the headers, the frame's state and bytes left) are the ones a byte moves. */
#define UART_RX_OFS_SKIP_COUNT 0
#define UART_RX_OFS_HEADERS 1
#define UART_RX_OFS_FRAME 2
#define UART_RX_PROGRESS_BYTES (UART_RX_OFS_FRAME + DXL_FRAME_BYTES)
#define UART_RX_MOVING_BYTES (UART_RX_OFS_FRAME + DXL_FRAME_OFS_LEFT + 1)

/* Reply states (uart_tx_state), the link's DXL_LINK_REPLY_* (link_port.c checks). */
#define UART_REPLY_IDLE 0
#define UART_REPLY_ARMED 1
#define UART_REPLY_WAITING 2 /* OCR1A counts down the Return Delay Time */
#define UART_REPLY_SENDING 3
#define UART_REPLY_DONE 4

/* How the RX interrupt takes the body of a packet the servo keeps (uart_rx_mode), chosen at
 * its LENGTH: UART_RX_HOLD wakes the main loop only at its checksum (the ring was empty, and
 * LENGTH <= UART_HOLD_MAX_LENGTH, so it fits); UART_RX_ARM as HOLD, and at its last byte but
 * one it arms the reply if the instruction is one the link listens for; UART_RX_EACH wakes the
 * main loop at every byte (it was busy, or the packet is longer). */
#define UART_RX_HOLD 0
#define UART_RX_ARM 1
#define UART_RX_EACH 2
#define UART_RX_EACH_BIT 1 /* uart_rx_mode bit set for UART_RX_EACH only */
/* The longest LENGTH held without waking: FF FF ID LENGTH and LENGTH bytes leave the main loop
 * the rest of the ring once it is woken (a SYNC_WRITE of 2 bytes to 30 servos is 94). */
#define UART_HOLD_MAX_LENGTH 96

/* Protocol values the assembly needs (dxl_protocol.h / dxl_servo.h spell them with a u
 * suffix the assembler does not take; uart.c checks they agree). */
#define DXL_HEADER_BYTE_ASM 0xFF
#define DXL_INST_PING_ASM 1
#define DXL_INST_WRITE_ASM 3
#define DXL_ID_BROADCAST_ASM 0xFE
#define UART_ARM_WRITE_MIN_ADDR 5    /* DXL_STREAM_WRITE_MIN_ADDR */
#define UART_STREAM_HEADER_BYTES 3   /* DXL_STREAM_HEADER_BYTES: FF FF ID */
#define UART_PACKET_HEADER_BYTES 4   /* DXL_PACKET_HEADER_BYTES: FF FF ID LENGTH, as kept */
#define UART_PACKET_OFS_INSTRUCTION 4 /* in the ring, from a kept packet's first byte */
#define UART_PACKET_OFS_FIRST_PARAM 5

/* uart_rx_armed: the RX ISR sets HELD when it arms a reply; uart_reply_publish() makes it
 * PUBLISHED (the reply's bytes are final: the checksum may be taken); uart_rx_take() clears it
 * with that checksum, and the gap rule when the checksum never came. */
#define UART_RX_ARMED_NONE 0
#define UART_RX_ARMED_HELD 1
#define UART_RX_ARMED_PUBLISHED 2

/* How an armed reply starts (uart_tx_mode), chosen by uart_reply_load from the delay. */
#define UART_START_NOW 0   /* Return Delay Time 0: the RX ISR writes UDR0 at once */
#define UART_START_SPIN 1  /* too close for OCR1A: the RX ISR spins on TCNT1 */
#define UART_START_TIMER 2 /* OCR1A a little early; TIMER1_COMPA spins, writes UDR0 */

/* UCSR0B in the three phases of the link. TXEN0 stays on: the idle TXD line is high. */
#define UART_UCSR0B_LISTEN (_BV(RXCIE0) | _BV(RXEN0) | _BV(TXEN0))
#define UART_UCSR0B_TALK (_BV(TXEN0) | _BV(UDRIE0))        /* receiver off: no own echo */
#define UART_UCSR0B_LAST_BYTE (_BV(TXEN0) | _BV(TXCIE0))   /* wait for the last stop bit */
#define UART_BUS_DIR_BIT PD2 /* PORTD: 1 = this servo drives the bus */

/* Reply timing, in Timer1 ticks (8 cycles). Every delayed start ends in a spin on TCNT1
 * that leaves at start = rx tick + delay - UART_SPIN_COMPENSATION_TICKS, calibrated in
 * simavr so the UDR0 write lands within 0..+10 cycles of the target (docs/firmware.md
 * "Reply timing"): it covers a TCNT1 read 6 cycles after the RX vector is entered (the
 * reference every path's tick is normalised to, uart_rx_fast.S) and the UDR0 write 9 cycles
 * after the spin sees its tick. TIMER1_COMPA is set UART_COMPA_EARLY_TICKS before start, so its
 * entry and a TIMER1_COMPB ISR (49 cycles, tiny_isr.S) just before it do not delay the reply. */
#define UART_SPIN_COMPENSATION_TICKS 2
/* The armed path reads TCNT1 25 cycles after that reference (it tests the armed state and
 * the checksum first, for the Return Delay Time 0 latency): 3 ticks, 1 cycle left over. */
#define UART_ARMED_READ_LATE_TICKS 3
#define UART_COMPA_EARLY_TICKS 12
/* Up to this delay the NOW path's own latency (UDR0 written 29 cycles after the RX vector is
 * entered; silicon adds its 4-cycle interrupt response) is nearer the target than a spin:
 * Return Delay Time 1 (32 cycles) starts as NOW. */
#define UART_NOW_MAX_DELAY_TICKS 7

#ifndef __ASSEMBLER__

#include <stdbool.h>
#include <stdint.h>


/* USART0 8N1, U2X, receiver on, bus released. baud_register: the Baud Rate item
 * (address 4), which is UBRR0 itself at 16 MHz with U2X. Needs timebase_init() (Timer1). */
void uart_init(uint8_t baud_register);

/* Reprograms UBRR0 (H then L). Only while the reply state is IDLE. */
void uart_set_baud(uint8_t baud_register);

/* Shared with the ISRs; declared here only so the accessors inline. */
extern volatile uint8_t uart_rx_ring[UART_RX_RING_BYTES];
extern volatile uint8_t uart_rx_head; /* RX ISR writes */
extern volatile uint8_t uart_rx_tail; /* main loop writes */
extern volatile uint8_t uart_tx_state; /* UART_REPLY_* */
/* The receiver's progress, the RX ISR's (uart_rx_fast.S defines it, one block): the bytes of a
 * packet not kept still to pass over (uart_rx_skip_count: the step's BODY of that packet), the
 * headers begun, a further 0xFF of one counted too (uart_rx_headers, wrapping: the gap's sign
 * of life), and its framing state (a dxl_frame_t, symbol uart_rx_frame; while skipping it is at
 * SEARCH). The main loop reads it a byte at a time, and writes it with interrupts off. */
extern volatile uint8_t uart_rx_progress[UART_RX_PROGRESS_BYTES];
extern volatile uint8_t uart_rx_armed;     /* UART_RX_ARMED_*: the RX ISR armed a packet whose
                                              last byte the main loop has not taken */
/* Bytes lost because the ring was full, and bytes the USART flagged (frame error or data
 * overrun), since power-up; both saturate at 255. The firmware does not report them: a host
 * reads them from RAM by symbol. */
extern volatile uint8_t uart_rx_dropped_count;
extern volatile uint8_t uart_rx_line_error_count;

/* Copies up to max of the oldest ring bytes to dst and takes them, never past the point where a
 * gap ended a packet, nor an armed packet's checksum before uart_reply_publish(); returns how
 * many (dxl_link_port_rx_take). */
uint8_t uart_rx_take(uint8_t *dst, uint8_t max);

/* True when the bytes taken end where a gap ended a packet (the next uart_rx_take goes on). */
bool uart_rx_at_gap(void);


/* The main loop's end of the gap rule, once per millisecond: when the receiver has been inside
 * a header, a skip or a packet it keeps, unmoved, for more than DXL_PACKET_GAP_TIMEOUT_MS, it
 * drops it (an armed reply goes back to IDLE) and the ring's bytes so far end at the gap. */
void uart_rx_gap_ms(void);

/* Loads ping_reply (DXL_PING_REPLY_BYTES) at delay_us and listens for id and mask
 * (dxl_link_port_listen), if the reply is IDLE and the ring empty; returns whether it did. */
bool uart_listen(const uint8_t *ping_reply, uint16_t delay_us, uint8_t id, uint8_t mask);

/* The rest of an armed or started streamed reply is in the loaded buffer: bytes[0..length), and
 * an armed packet's checksum may be taken. Any state. Main loop only, interrupts on. */
void uart_reply_publish(uint8_t length);

/* State IDLE: sends bytes[0..length) (length >= 2, kept unchanged until DONE) 2 us x RDT
 * (delay_us) after the RX interrupt of the last byte taken from the ring, if that moment is
 * still ahead (TIMER1_COMPA, or a spin of at most 16 ticks), at once otherwise. Main loop only,
 * interrupts on. */
void uart_reply_send(const uint8_t *bytes, uint8_t length, uint16_t delay_us);

static inline uint8_t uart_reply_state(void) { return uart_tx_state; }

/* DONE -> IDLE, once the main loop has acted on what follows the reply. */
static inline void uart_reply_finish(void) { uart_tx_state = UART_REPLY_IDLE; }

/* The RX interrupt's slow path (uart_rx_fast.S calls it, interrupts off): a byte the assembly
 * does not frame, through dxl_frame_step(): a LENGTH below 2 (which may begin a Protocol 2.0
 * frame) and that frame's bytes, and the LENGTH of a packet kept while the link does not listen
 * (its header goes into the ring, UART_RX_EACH). */
void uart_rx_frame_byte(uint8_t byte);

#endif /* __ASSEMBLER__ */
#endif
