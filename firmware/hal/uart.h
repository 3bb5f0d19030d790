/* Half-duplex Dynamixel bus on USART0 (docs/hardware.md "UART", "Pins").
 *
 * Receive: the RX ISR (uart_rx.S) moves each byte into a single-producer single-consumer
 * ring and notes the Timer1 tick at which it read the byte. The ISR is the only writer of
 * uart_rx_head (it also moves it back over a packet the sniff drops, while the main loop
 * leaves the ring alone), the main loop the only writer of uart_rx_tail; both are 8-bit and
 * free-running (the ring index is the low bits), so each is read and written in one
 * instruction and never torn; the ring is full when head - tail == UART_RX_RING_BYTES.
 *
 * Transmit: one status packet at a time, from a buffer the caller keeps unchanged until
 * uart_reply_state() reports UART_REPLY_DONE. PD2 (bus direction) is high and the receiver
 * is off (RXEN0 = 0: no own echo) from the first byte until TX-complete of the last byte.
 *
 * Reply timing (docs/policy.md "Replies"): the first byte is written to UDR0 2 us x Return Delay
 * Time after the RX interrupt of the instruction's last byte. Two ways to start it:
 *   - armed: the RX ISR's sniff (below) arms the reply at the packet's last byte before the
 *     checksum, with the checksum that completes it; the RX ISR starts it the moment that
 *     byte arrives and matches (RDT 0-1: writes UDR0 itself; short delays: spins on TCNT1;
 *     longer: sets OCR1A and TIMER1_COMPA starts it);
 *   - late: after the packet was handled, from the tick of its last byte if that moment is
 *     still ahead, at once otherwise (uart_reply_start).
 *
 * Execution contexts: USART_RX, USART_UDRE and TIMER1_COMPA (uart_rx.S), USART_TX (uart.c)
 * ISRs; every function here is for the main loop only.
 * Budget: at 1 Mbps a byte arrives every 160 cycles (docs/firmware.md has the measured ISR
 * costs).
 *
 * This header is also included by uart_rx.S: the constants the ISR shares are plain
 * #defines, the C declarations sit under !__ASSEMBLER__.
 */
#ifndef HAL_UART_H
#define HAL_UART_H

#include <avr/io.h>

/* Ring size: a power of two, <= 128 (8-bit free-running indices). It holds the bytes a sniff
 * holds (at most UART_SNIFF_MAX_HELD) and the bytes that arrive while the main loop is busy
 * with something else (a control tick, a packet); the main loop moves them into the packet
 * finder in batches (docs/firmware.md "Receive"). */
#define UART_RX_RING_BYTES 128
#define UART_RX_RING_MASK (UART_RX_RING_BYTES - 1)

/* Reply states. Transitions: IDLE -> ARMED (main) -> IDLE (RX ISR: checksum differs;
 * main: disarm) or -> WAITING / SENDING (RX ISR); IDLE -> WAITING / SENDING (main: start);
 * WAITING -> SENDING (COMPA ISR); SENDING -> DONE (TX ISR, bus released); DONE -> IDLE
 * (main, uart_reply_finish). */
#define UART_REPLY_IDLE 0
#define UART_REPLY_ARMED 1
#define UART_REPLY_WAITING 2 /* OCR1A counts down the Return Delay Time */
#define UART_REPLY_SENDING 3
#define UART_REPLY_DONE 4

/* Sniff state (uart_sniff): the byte the RX ISR expects next of the packet it frames
 * (uart_rx.S); below ARMED the sniff runs and holds the ring; ARMED = it armed the reply at
 * the last byte before the checksum (main loop: take it over); OFF = the finder's. */
#define UART_SNIFF_ID 2 /* 0, 1: the header's FF FF */
#define UART_SNIFF_LENGTH 3
#define UART_SNIFF_INSTRUCTION 4
#define UART_SNIFF_FIRST_PARAM 5
#define UART_SNIFF_BODY 6
#define UART_SNIFF_CHECKSUM 7 /* a packet framed, not armed: its checksum is next */
#define UART_SNIFF_ARMED 8
#define UART_SNIFF_OFF 0xFF
/* What the sniff does with the packet it frames, decided at its ID and instruction
 * (uart_sniff_fate): arm its reply, drop it (another servo's: skipped from its LENGTH on),
 * or hand it to the finder whole at its checksum (broadcast, or this servo's, not armed). */
#define UART_FATE_ARM 0
#define UART_FATE_DROP 1
#define UART_FATE_HAND_OVER 2
/* Bytes the sniff holds, bounded without a per-byte test: the header FF FF ID (put into the
 * ring at the LENGTH of a packet the servo keeps; before that the sniff holds it in its state
 * alone), then LENGTH + 1 bytes with LENGTH at most UART_SNIFF_MAX_LENGTH (a SYNC_WRITE of 2
 * bytes to 30 servos is 94). The rest of the ring is the main loop's margin once a sniff ends
 * part-way (28 bytes: 280 us at 1 Mbps). */
#define UART_SNIFF_MAX_HEADER_HELD 3
#define UART_SNIFF_MAX_LENGTH 96
#define UART_SNIFF_MAX_HELD (UART_SNIFF_MAX_HEADER_HELD + 1 + UART_SNIFF_MAX_LENGTH)
/* Protocol values the assembly needs (dxl_protocol.h / dxl_servo.h spell them with a u
 * suffix the assembler does not take; uart.c checks they agree). */
#define DXL_HEADER_BYTE_ASM 0xFF
#define DXL_INST_PING_ASM 1
#define DXL_INST_WRITE_ASM 3
#define DXL_ID_BROADCAST_ASM 0xFE
#define DXL_PROTOCOL2_ID_ASM 0xFD /* FF FF FD 00: a Protocol 2.0 header (dxl_packet.c) */
#define UART_SNIFF_WRITE_MIN_ADDR 5 /* DXL_STREAM_WRITE_MIN_ADDR */
#define UART_STREAM_HEADER_BYTES 3   /* DXL_STREAM_HEADER_BYTES: FF FF ID */

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
 * reference every path's tick is normalised to, uart_rx.S) and the UDR0 write 9 cycles after
 * the spin sees its tick. TIMER1_COMPA is set UART_COMPA_EARLY_TICKS before start, so its
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

/* USART0 8N1, U2X, receiver on, bus released. baud_register: the Baud Rate item (address 4),
 * which is UBRR0 itself at 16 MHz with U2X. Needs timebase_init() (Timer1) before use. */
void uart_init(uint8_t baud_register);

/* Reprograms UBRR0 (H then L). Only while the reply state is IDLE. */
void uart_set_baud(uint8_t baud_register);

/* Shared with the ISRs; declared here only so the accessors below inline. */
extern volatile uint8_t uart_rx_ring[UART_RX_RING_BYTES];
extern volatile uint8_t uart_rx_head; /* RX ISR writes */
extern volatile uint8_t uart_rx_tail; /* main loop writes */
extern volatile uint8_t uart_tx_state; /* UART_REPLY_* */
/* Bytes lost because the ring was full, and bytes the USART flagged (frame error or data
 * overrun), since power-up; both saturate at 255. The firmware does not report them: a host
 * reads them from RAM by symbol. */
extern volatile uint8_t uart_rx_dropped_count;
extern volatile uint8_t uart_rx_line_error_count;

/* True when the ring holds a byte. */
static inline bool uart_rx_available(void) { return uart_rx_head != uart_rx_tail; }

static inline uint8_t uart_reply_state(void) { return uart_tx_state; }

/* The sniff (uart_rx.S). uart_sniff_start: with the ready PING reply loaded, state IDLE and
 * the ring and the finder empty, the RX ISR frames the packets that come. It reads the header
 * FF FF ID LENGTH as the finder would (a byte that cannot be a header's is dropped, further
 * FFs before the ID are still the header, LENGTH < 2 is no packet) without storing it, in
 * uart_sniff 0..UART_SNIFF_LENGTH; at the LENGTH:
 *   - another servo's (not broadcast): the RX ISR skips the LENGTH bytes that follow
 *     (uart_skip_count counts them down), and the sniff goes on with the next header;
 *   - this servo's or broadcast: FF FF ID and the LENGTH go into the ring, and
 *       - one for id with an instruction whose bit is set in mask (dxl_servo_stream_mask):
 *         the reply is armed at its last byte before the checksum (uart_sniff =
 *         UART_SNIFF_ARMED; uart_sniff_end = the ring position just after the checksum). A
 *         PING answers with the loaded reply; anything else streams its first
 *         UART_STREAM_HEADER_BYTES and waits for uart_reply_publish();
 *       - anything else (LENGTH over UART_SNIFF_MAX_LENGTH at once, else at its checksum):
 *         OFF, the held bytes are the finder's.
 * While the sniff runs (uart_sniff < UART_SNIFF_ARMED) the main loop leaves the ring alone
 * and the bytes do not wake it. Does nothing when a byte came first. A header that stops
 * part-way is the link layer's to drop after the gap (dxl_link.c), as the finder would.
 * uart_sniff_stop_part_way: ends a running sniff past its LENGTH (not one that has armed);
 * the held bytes are then the finder's. */
extern volatile uint8_t uart_sniff;
extern volatile uint8_t uart_sniff_end;
void uart_sniff_start(uint8_t id, uint8_t mask);
void uart_sniff_stop_part_way(void);
/* Bytes of another servo's packet the RX ISR still skips (0: none). The main loop writes 0
 * (one store: the ISR's decrement cannot tear it) to end a skip after a gap in the bytes. */
extern volatile uint8_t uart_skip_count;

/* The rest of a streamed reply is in the loaded buffer: bytes[0..length). Any state. Main loop
 * only, interrupts on (its atomic block ends with SEI). */
void uart_reply_publish(uint8_t length);

/* Sets the status packet to send next (bytes[0..length), length >= 2) and its delay after
 * the RX interrupt of the instruction's last byte (dxl_response_t.delay_us: 2 us x Return
 * Delay Time, 0..508). State must be IDLE. The bytes stay the caller's; keep them unchanged
 * until the state is DONE. */
void uart_reply_load(const uint8_t *bytes, uint8_t length, uint16_t delay_us);

/* ARMED -> IDLE. Returns false when the RX ISR had already started the reply. Main loop only,
 * interrupts on (its atomic block ends with SEI). */
bool uart_reply_disarm(void);

/* Starts the loaded reply after a packet the main loop has just completed (its last byte
 * popped): 2 us x RDT after that byte's RX interrupt if that is still ahead (TIMER1_COMPA,
 * or a spin of at most 16 ticks), else now. Main loop only, interrupts on (its atomic block
 * ends with SEI). */
void uart_reply_start(void);

/* DONE -> IDLE, once the main loop has acted on what follows the reply. */
static inline void uart_reply_finish(void) { uart_tx_state = UART_REPLY_IDLE; }

#endif /* __ASSEMBLER__ */
#endif
