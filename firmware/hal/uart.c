/* USART0 half-duplex bus: set-up, the receiver's slow path and its gap, listening, reply
 * scheduling and the TX-complete interrupt. The RX interrupt's hot paths are in
 * uart_rx_fast.S, the transmit interrupts in uart_tx_isr.S. See uart.h. */
#include "uart.h"

#include <avr/interrupt.h>
#include <stddef.h>
#include <util/atomic.h>

#include "board.h"
#include "dxl_config.h"
#include "dxl_protocol.h"
#include "dxl_servo.h"
#include "timebase.h"

#if (UART_RX_RING_BYTES & UART_RX_RING_MASK) != 0 || UART_RX_RING_BYTES > 128
#error "UART_RX_RING_BYTES must be a power of two <= 128 (8-bit free-running indices)"
#endif
_Static_assert(DXL_HEADER_BYTE_ASM == DXL_HEADER_BYTE && DXL_INST_PING_ASM == DXL_INST_PING &&
                   DXL_INST_WRITE_ASM == DXL_INST_WRITE && DXL_ID_BROADCAST_ASM == DXL_ID_BROADCAST &&
                   UART_ARM_WRITE_MIN_ADDR == DXL_STREAM_WRITE_MIN_ADDR &&
                   UART_STREAM_HEADER_BYTES == DXL_STREAM_HEADER_BYTES &&
                   UART_PACKET_OFS_INSTRUCTION == DXL_PACKET_HEADER_BYTES &&
                   UART_PACKET_OFS_FIRST_PARAM == DXL_PACKET_HEADER_BYTES + 1u,
               "uart.h's assembler copies of the protocol values");
_Static_assert(UART_PACKET_HEADER_BYTES == DXL_PACKET_HEADER_BYTES, "uart.h's header size");
_Static_assert(UART_RX_EACH == (1u << UART_RX_EACH_BIT) && (UART_RX_HOLD & (1u << UART_RX_EACH_BIT)) == 0 &&
                   (UART_RX_ARM & (1u << UART_RX_EACH_BIT)) == 0,
               "uart_rx_fast.S tests one bit for UART_RX_EACH");
/* A packet held while listening (at most its 4 header bytes and UART_HOLD_MAX_LENGTH more, in
 * a ring that was empty) leaves the main loop this margin of the ring once it is woken: 24
 * bytes, 240 us at 1 Mbps, against a main-loop pass of at most a control tick (under 1.2k
 * cycles, 75 us). */
_Static_assert(UART_RX_RING_BYTES - (DXL_PACKET_HEADER_BYTES + UART_HOLD_MAX_LENGTH) >= 24,
               "a held packet leaves the main loop no margin");
_Static_assert(DXL_ID_MAX + 1u <= UINT8_MAX, "uart_listening holds an ID + 1");
#if UART_COMPA_EARLY_TICKS > 63 || UART_SPIN_COMPENSATION_TICKS + UART_ARMED_READ_LATE_TICKS > 63
#error "compensation must fit SBIW in uart_rx_fast.S"
#endif

/* OCR1A must still lie ahead of TCNT1 when written: from the main loop (late start) by this
 * much, else the main loop spins itself; the RX ISR writes it about 8 ticks after the tick
 * it read, so armed delays need this much room past the early margin, else they spin in
 * the RX ISR. */
#define LATE_MIN_LEAD_TICKS 4
#define ARMED_MIN_OFFSET_TICKS 10

/* The receiver (RX ISR; the main loop reads them with interrupts off, or one byte at a time). */
volatile uint8_t uart_rx_ring[UART_RX_RING_BYTES];
volatile uint8_t uart_rx_head;
volatile uint8_t uart_rx_tail;
volatile uint16_t uart_rx_tick;            /* TCNT1 at the last byte of the newest kept packet */
volatile uint8_t uart_rx_dropped_count;
volatile uint8_t uart_rx_line_error_count;
volatile uint8_t uart_rx_mode;             /* UART_RX_* of the kept packet under way */
volatile uint8_t uart_rx_armed;
volatile uint8_t uart_rx_armed_end;        /* ring index just after the armed packet's checksum */
volatile uint8_t uart_listening;           /* 0: not listening (as at power-up); else the ID
                                              listened for + 1 */
volatile uint8_t uart_listen_mask;

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
const uint8_t *volatile uart_tx_bytes; /* the loaded reply (UDRE ISR reads) */
volatile uint8_t uart_tx_length;

/* The gap (uart_rx_gap_ms): the receiver's moving bytes at the last millisecond inside a
 * header, packet or skip; gap_age_ms 0 outside one, else 1 + the milliseconds since it was last
 * seen to move; where the last gap ended a packet in the ring. */
static uint8_t gap_seen[UART_RX_MOVING_BYTES];
static uint8_t gap_age_ms;
static bool gap_cut;
static uint8_t gap_cut_at;

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
  UCSR0B = UART_UCSR0B_LISTEN;
}

/* Appends a byte to the ring, or counts it dropped when the ring is full. Interrupts off. */
static void rx_put(uint8_t byte) {
  const uint8_t head = uart_rx_head;
  if ((uint8_t)(head - uart_rx_tail) >= UART_RX_RING_BYTES) {
    if (uart_rx_dropped_count != UINT8_MAX) {
      uart_rx_dropped_count++;
    }
    return;
  }
  uart_rx_ring[head & UART_RX_RING_MASK] = byte;
  uart_rx_head = (uint8_t)(head + 1u);
}

void uart_rx_frame_byte(uint8_t byte) {
  /* interrupts off: nothing else reads the frame meanwhile */
  dxl_frame_t *frame = (dxl_frame_t *)&uart_rx_progress[UART_RX_OFS_FRAME];
  if (dxl_frame_step(frame, byte) == DXL_BYTE_LENGTH) {
    uart_rx_mode = UART_RX_EACH; /* kept while not listening: the main loop takes it as it comes */
    rx_put(DXL_HEADER_BYTE);
    rx_put(DXL_HEADER_BYTE);
    rx_put(frame->id);
    rx_put(frame->length);
    board_wake_set();
  }
}

bool uart_rx_at_gap(void) { return gap_cut && uart_rx_tail == gap_cut_at; }

uint8_t uart_rx_take(uint8_t *dst, uint8_t max) {
  uint8_t tail = uart_rx_tail;
  if (uart_rx_at_gap()) {
    gap_cut = false; /* the caller has dropped the packet the gap ended */
  }
  uint8_t count = (uint8_t)((gap_cut ? gap_cut_at : uart_rx_head) - tail);
  if (uart_rx_armed == UART_RX_ARMED_HELD) {
    count = (uint8_t)(uart_rx_armed_end - 1u - tail); /* up to its checksum, which waits */
  }
  if (count > max) {
    count = max;
  }
  for (uint8_t n = count; n != 0; n--) {
    *dst++ = uart_rx_ring[tail++ & UART_RX_RING_MASK];
  }
  uart_rx_tail = tail;
  /* The armed packet's last byte taken (the link takes it alone, or with the bytes before it:
   * never past it, dxl_finder_slot; the RX ISR arms again only after a new listen). */
  if (tail == uart_rx_armed_end) {
    uart_rx_armed = UART_RX_ARMED_NONE;
  }
  return count;
}

/* Whether the receiver has moved since the last call: every byte inside a header, a skip or a
 * kept packet changes one of its moving bytes (the state, the bytes left, the skip count; a
 * further 0xFF of a header the headers count). Read with interrupts on: a byte during the
 * reads is seen at the next call at the latest. */
static DXL_ONE_COPY bool rx_moved(void) {
  bool moved = false;
  for (uint8_t i = 0; i < UART_RX_MOVING_BYTES; i++) {
    const uint8_t now = uart_rx_progress[i];
    if (gap_seen[i] != now) {
      gap_seen[i] = now;
      moved = true;
    }
  }
  return moved;
}

void uart_rx_gap_ms(void) {
  /* Interrupts on: this runs every millisecond, and an interrupts-off window would delay the
   * RX interrupt. Outside a header, a packet or a skip nothing can be cut: gap_age_ms 0. The
   * first millisecond inside one counts as moved (a byte came to get there), and so do those
   * that see a byte; the 101st after the last of them without one is more than 100 ms after
   * its byte. */
  if (uart_rx_progress[UART_RX_OFS_FRAME + DXL_FRAME_OFS_STATE] == DXL_FRAME_SEARCH &&
      uart_rx_progress[UART_RX_OFS_SKIP_COUNT] == 0) {
    gap_age_ms = 0;
    return;
  }
  if (rx_moved() || gap_age_ms == 0) {
    gap_age_ms = 1;
  } else if (++gap_age_ms > DXL_PACKET_GAP_TIMEOUT_MS + 1u) {
    ATOMIC_BLOCK(ATOMIC_FORCEON) { /* main loop only: interrupts on */
      if (!rx_moved()) { /* no byte since: a gap */
        uart_rx_progress[UART_RX_OFS_FRAME + DXL_FRAME_OFS_STATE] = DXL_FRAME_SEARCH;
        uart_rx_progress[UART_RX_OFS_SKIP_COUNT] = 0;
        if (uart_rx_armed != UART_RX_ARMED_NONE) {
          uart_rx_armed = UART_RX_ARMED_NONE;
          uart_tx_state = UART_REPLY_IDLE; /* armed: its checksum never came */
        }
        /* A second gap before the main loop has reached the first one's point (only when the
         * ring waits behind a reply of more than 100 ms, at the slowest bauds) moves it. */
        gap_cut = true;
        gap_cut_at = uart_rx_head;
      }
    }
  }
}

/* uart_tx_isr.S, shared with the RX ISR and TIMER1_COMPA; interrupts off: once TCNT1 has
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

/* The reply to send next and its start mode, state IDLE. */
static __attribute__((noinline)) void reply_load(const uint8_t *bytes, uint8_t length, uint16_t delay_us) {
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

bool uart_listen(const uint8_t *ping_reply, uint16_t delay_us, uint8_t id, uint8_t mask) {
  if (uart_tx_state != UART_REPLY_IDLE) {
    return false;
  }
  /* With the reply IDLE nothing reads what this loads: the RX ISR arms only while listening,
   * and a listening link reloads only while the receiver is not between a header's ID and its
   * checksum (DXL_LINK_RX_BUSY), several byte times before it could arm. */
  reply_load(ping_reply, DXL_PING_REPLY_BYTES, delay_us);
  bool listening = false;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { /* also at power-up, before SEI */
    if (uart_rx_head == uart_rx_tail) {
      uart_rx_head = 0; /* the packet kept next lies from index 0 (uart.h) */
      uart_rx_tail = 0;
      gap_cut = false;
      uart_listen_mask = mask;
      uart_listening = (uint8_t)(id + 1u);
      listening = true;
    }
  }
  return listening;
}

void uart_reply_send(const uint8_t *bytes, uint8_t length, uint16_t delay_us) {
  reply_load(bytes, length, delay_us);
  ATOMIC_BLOCK(ATOMIC_FORCEON) { /* main loop only: interrupts on */
    /* The packet's last byte is the newest kept one unless more came since. */
    reply_start_late(uart_rx_head == uart_rx_tail ? uart_rx_tick : TCNT1);
  }
}

void uart_reply_publish(uint8_t length) {
  ATOMIC_BLOCK(ATOMIC_FORCEON) { /* main loop only: interrupts on */
    uart_tx_length = length;
    uart_tx_published = length;
    if (uart_rx_armed != UART_RX_ARMED_NONE) {
      uart_rx_armed = UART_RX_ARMED_PUBLISHED;
    }
    if (UCSR0B == _BV(TXEN0)) {
      UCSR0B = UART_UCSR0B_TALK; /* stalled: UDRE fires at once and goes on */
    }
  }
}
