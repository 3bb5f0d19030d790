/* USART0 half-duplex bus: set-up, reply scheduling and transmission. The RX ISR is in
 * uart_rx.S. See uart.h. */
#include "uart.h"

#include <avr/interrupt.h>
#include <util/atomic.h>

#include "dxl_protocol.h"
#include "dxl_servo.h"
#include "board.h"
#include "timebase.h"

#if (UART_RX_RING_BYTES & UART_RX_RING_MASK) != 0 || UART_RX_RING_BYTES > 128
#error "UART_RX_RING_BYTES must be a power of two <= 128 (8-bit free-running indices)"
#endif
_Static_assert(DXL_HEADER_BYTE_ASM == DXL_HEADER_BYTE && DXL_INST_PING_ASM == DXL_INST_PING &&
                   DXL_INST_WRITE_ASM == DXL_INST_WRITE && DXL_ID_BROADCAST_ASM == DXL_ID_BROADCAST &&
                   UART_SNIFF_WRITE_MIN_ADDR == DXL_STREAM_WRITE_MIN_ADDR &&
                   UART_STREAM_HEADER_BYTES == DXL_STREAM_HEADER_BYTES,
               "uart.h's assembler copies of the protocol values");
/* The sniff's held bytes leave the main loop at least this margin of the ring once a sniff
 * ends part-way (uart.h): 24 bytes, 240 us at 1 Mbps (the bounds leave 28), against a
 * main-loop pass of at most a control tick (under 1.2k cycles, 75 us): a sniff runs only
 * while the main loop has no packet to handle. */
_Static_assert(UART_RX_RING_BYTES - UART_SNIFF_MAX_HELD >= 24, "the sniff's bounds leave the main loop no margin");
#if UART_COMPA_EARLY_TICKS > 63 || UART_SPIN_COMPENSATION_TICKS + UART_ARMED_READ_LATE_TICKS > 63
#error "compensation must fit SBIW in uart_rx.S"
#endif

/* OCR1A must still lie ahead of TCNT1 when written: from the main loop (late start) by this
 * much, else the main loop spins itself; the RX ISR writes it about 8 ticks after the tick
 * it read, so armed delays need this much room past the early margin, else they spin in
 * the RX ISR. */
#define LATE_MIN_LEAD_TICKS 4
#define ARMED_MIN_OFFSET_TICKS 10

/* Receive ring (SPSC, see uart.h) and what the RX ISR records. */
volatile uint8_t uart_rx_ring[UART_RX_RING_BYTES];
volatile uint8_t uart_rx_head;
volatile uint8_t uart_rx_tail;
volatile uint16_t uart_rx_tick;       /* RX ISR: TCNT1 when it read the newest byte */
volatile uint8_t uart_rx_dropped_count; /* RX ISR */
volatile uint8_t uart_rx_line_error_count; /* RX ISR */

/* Reply. The main loop writes these while the state is IDLE, then publishes them with the
 * state change (inside ATOMIC_BLOCK, whose barriers order the stores); the ISRs read them
 * only once the state says a reply is armed or under way. */
volatile uint8_t uart_tx_state;
volatile uint8_t uart_tx_checksum;    /* ARMED: the byte that completes the packet */
volatile uint8_t uart_tx_mode;        /* UART_START_* */
volatile uint16_t uart_tx_delay_ticks; /* Return Delay Time in Timer1 ticks */
volatile uint8_t uart_tx_next;        /* UDRE ISR: index of the next byte to write */
volatile uint16_t uart_tx_start_tick; /* WAITING: TIMER1_COMPA spins until TCNT1 reaches it */
volatile uint8_t uart_tx_published;   /* UDRE ISR sends bytes[0..published); RX ISR, main */
volatile uint8_t uart_sniff; /* RX ISR and main (ATOMIC); OFF from uart_init() */
volatile uint8_t uart_sniff_id;       /* the sniff's own state (RX ISR), set by uart_sniff_start */
volatile uint8_t uart_sniff_mask;
volatile uint8_t uart_sniff_instruction;
volatile uint8_t uart_sniff_sum;
volatile uint8_t uart_sniff_count;
volatile uint8_t uart_sniff_end;
volatile uint8_t uart_sniff_fate;         /* RX ISR: UART_FATE_* of the packet being framed */
volatile uint8_t uart_skip_count;         /* RX ISR; main: 0 after a gap */
const uint8_t *volatile uart_tx_bytes; /* the loaded reply (UDRE ISR reads) */
volatile uint8_t uart_tx_length;

void uart_set_baud(uint8_t baud_register) {
  UBRR0H = 0;
  UBRR0L = baud_register; /* written last: simavr latches the baud here */
}

void uart_init(uint8_t baud_register) {
  PORTD &= (uint8_t)~_BV(UART_BUS_DIR_BIT);
  DDRD |= _BV(UART_BUS_DIR_BIT);
  UCSR0A = _BV(U2X0);
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00); /* 8N1 */
  uart_set_baud(baud_register);
  uart_sniff = UART_SNIFF_OFF;
  uart_skip_count = 0;
  UCSR0B = UART_UCSR0B_LISTEN;
}

/* uart_rx.S, shared with the RX ISR and TIMER1_COMPA; interrupts off: once TCNT1 has
 * reached tick (at once if it has passed), drives the bus, writes the first byte (every status
 * packet starts with 0xFF) and hands the rest to the UDRE ISR. */
void uart_start_at(uint16_t tick);

/* Starts the loaded reply relative to rx_tick, the TCNT1 value the RX ISR read for the
 * packet's last byte, from the main loop: the moment may be close or already past.
 * Interrupts off. */
static void reply_start_late(uint16_t rx_tick) {
  const uint16_t start = (uint16_t)(rx_tick + uart_tx_delay_ticks - UART_SPIN_COMPENSATION_TICKS);
  const uint16_t ocr = (uint16_t)(start - UART_COMPA_EARLY_TICKS);
  if ((int16_t)(ocr - TCNT1) > LATE_MIN_LEAD_TICKS) {
    uart_tx_start_tick = start;
    OCR1A = ocr; /* a stale OCF1A: TIMER1_COMPA ignores it */
    TIMSK1 = _BV(OCIE1A) | _BV(OCIE1B);
    uart_tx_state = UART_REPLY_WAITING;
    return;
  }
  uart_start_at(start); /* at most UART_COMPA_EARLY_TICKS + LATE_MIN_LEAD_TICKS ahead, or past */
}

/* The last stop bit has left: release the bus, listen again. */
ISR(USART_TX_vect) {
  PORTD &= (uint8_t)~_BV(UART_BUS_DIR_BIT);
  UCSR0B = UART_UCSR0B_LISTEN;
  uart_tx_state = UART_REPLY_DONE;
  GPIOR0 |= _BV(BOARD_WAKE_BIT);
}

__attribute__((noinline)) void uart_reply_load(const uint8_t *bytes, uint8_t length, uint16_t delay_us) {
  uart_tx_bytes = bytes;
  uart_tx_length = length;
  uart_tx_published = length;
  const uint16_t delay_ticks = (uint16_t)(delay_us * TIMEBASE_TICKS_PER_US);
  uart_tx_delay_ticks = delay_ticks;
  if (delay_ticks <= UART_NOW_MAX_DELAY_TICKS) {
    uart_tx_mode = UART_START_NOW;
  } else if (delay_ticks >= UART_SPIN_COMPENSATION_TICKS + UART_COMPA_EARLY_TICKS + ARMED_MIN_OFFSET_TICKS) {
    uart_tx_mode = UART_START_TIMER;
  } else {
    uart_tx_mode = UART_START_SPIN;
  }
}

/* uart_reply_disarm(), uart_reply_start() and uart_reply_publish() run in the main loop only,
 * interrupts on: their atomic blocks end with SEI (ATOMIC_FORCEON) instead of restoring a
 * saved SREG, 10 B less flash on the ATmega88. (uart_sniff_start() also runs at power-up,
 * before SEI, so it restores.) */

bool uart_reply_disarm(void) {
  ATOMIC_BLOCK(ATOMIC_FORCEON) {
    if (uart_tx_state == UART_REPLY_ARMED) {
      uart_tx_state = UART_REPLY_IDLE;
      return true; /* the block's SEI runs on the way out; no bool kept: 4 B less flash */
    }
  }
  return false;
}

void uart_reply_start(void) {
  ATOMIC_BLOCK(ATOMIC_FORCEON) {
    /* The packet's last byte is the newest unless more came since. */
    reply_start_late(uart_rx_head == uart_rx_tail ? uart_rx_tick : TCNT1);
  }
}

void uart_reply_publish(uint8_t length) {
  ATOMIC_BLOCK(ATOMIC_FORCEON) {
    uart_tx_length = length;
    uart_tx_published = length;
    if (UCSR0B == _BV(TXEN0)) {
      UCSR0B = UART_UCSR0B_TALK; /* stalled: UDRE fires at once and goes on */
    }
  }
}

void uart_sniff_start(uint8_t id, uint8_t mask) {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    if (uart_tx_state == UART_REPLY_IDLE && uart_rx_head == uart_rx_tail) {
      uart_sniff_id = id;
      uart_sniff_mask = mask;
      uart_sniff = 0;
    }
  }
}

void uart_sniff_stop_part_way(void) {
  ATOMIC_BLOCK(ATOMIC_FORCEON) { /* main loop only: interrupts on */
    if (uart_sniff < UART_SNIFF_ARMED) {
      uart_sniff = UART_SNIFF_OFF;
    }
  }
}
