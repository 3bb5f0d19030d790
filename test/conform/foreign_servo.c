/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A Dynamixel Protocol 1.0 servo written apart from this project's firmware, for the tests of
 * `scripts/ax12 conform` on imperfect devices and of `scripts/ax12 serve --elf` with a program
 * that is not this project's (test/conform/test_foreign.py, docs/conform.md "Testing your own
 * firmware on the emulated bus"). One plain C file for the ATmega328P at 16 MHz on the board of
 * docs/hardware.md (USART0, the bus direction on PD2): no bootloader, no watchdog, no EEPROM,
 * no .mmcu section, as a builder's first sketch would be. It sleeps while the bus is idle, so
 * that the emulator need not simulate a busy loop in real time.
 *
 * Built as it is, it answers as docs/policy.md says for what the tests ask of it: PING, READ,
 * WRITE, REG_WRITE, ACTION, RESET and SYNC_WRITE, the write ranges, the Status Return Level,
 * the Return Delay Time, the Angle Limit condition. Each FOREIGN_* macro adds one defect, a
 * failure mode the conformance tool must name:
 *   FOREIGN_OWN_ITEMS      addresses 6..9 hold items of its own and refuse every write
 *                          (Range Error): the AX-12's angle limits cannot be set
 *   FOREIGN_DEAF_MS=N      a Protocol 2.0 header (FF FF FD 00) makes it ignore the bus for N ms
 *   FOREIGN_IGNORE_RDT     answers at once, whatever the Return Delay Time
 *   FOREIGN_NO_RANGE_CHECK takes any value into a writable item of the RAM area (an invalid
 *                          Lock = 2 stays); the EEPROM area's ranges are still checked
 *   FOREIGN_RO_HOLE        refuses a one-byte write to a read-only address, but a wider one
 *                          writes it (a 2-byte WRITE at 0 changes the Model Number)
 *   FOREIGN_HALF_DROP      a one-byte WRITE into a two-byte item is answered and not written
 *   FOREIGN_NO_BROADCAST   never acts on or answers the broadcast ID
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdbool.h>
#include <stdint.h>

#define TABLE_SIZE 50u
#define EEPROM_SIZE 24u
#define BROADCAST 0xFEu
#define GAP_TICKS 200000ul /* 100 ms in Timer1 ticks of 0.5 us, a partial packet's gap */

enum { ERR_ANGLE = 0x02, ERR_RANGE = 0x08, ERR_CHECKSUM = 0x10, ERR_INSTRUCTION = 0x40 };
enum { PING = 1, READ = 2, WRITE = 3, REG_WRITE = 4, ACTION = 5, RESET = 6, SYNC_WRITE = 0x83 };
enum { A_ID = 3, A_BAUD = 4, A_RDT = 5, A_CW = 6, A_CCW = 8, A_MAX_TORQUE = 14, A_SRL = 16, A_GOAL = 30,
       A_SPEED = 32, A_TORQUE_LIMIT = 34, A_PRESENT = 36, A_REGISTERED = 44, A_LOCK = 47 };
enum { RO, RW, RESERVED };

typedef struct {
  uint8_t addr, size, access;
  uint16_t min, max, factory;
} item_t;

/* The AX-12's control table (the 2006 manual). */
static const item_t items[] = {
    {0, 2, RO, 0, 0, 12},         {2, 1, RO, 0, 0, 1},          {3, 1, RW, 0, 253, 1},
    {4, 1, RW, 0, 254, 1},        {5, 1, RW, 0, 254, 250},      {6, 2, RW, 0, 1023, 0},
    {8, 2, RW, 0, 1023, 1023},    {10, 1, RESERVED, 0, 0, 0},   {11, 1, RW, 0, 150, 85},
    {12, 1, RW, 50, 250, 60},     {13, 1, RW, 50, 250, 190},    {14, 2, RW, 0, 1023, 1023},
    {16, 1, RW, 0, 2, 2},         {17, 1, RW, 0, 127, 4},       {18, 1, RW, 0, 127, 4},
    {19, 1, RW, 0, 1, 0},         {20, 2, RO, 0, 0, 0},         {22, 2, RO, 0, 0, 1023},
    {24, 1, RW, 0, 1, 0},         {25, 1, RW, 0, 1, 0},         {26, 1, RW, 0, 254, 0},
    {27, 1, RW, 0, 254, 0},       {28, 1, RW, 1, 254, 32},      {29, 1, RW, 1, 254, 32},
    {30, 2, RW, 0, 1023, 512},    {32, 2, RW, 0, 1023, 0},      {34, 2, RW, 0, 1023, 1023},
    {36, 2, RO, 0, 0, 512},       {38, 2, RO, 0, 0, 0},         {40, 2, RO, 0, 0, 0},
    {42, 1, RO, 0, 0, 120},       {43, 1, RO, 0, 0, 25},        {44, 1, RW, 0, 1, 0},
    {45, 1, RESERVED, 0, 0, 0},   {46, 1, RO, 0, 0, 0},         {47, 1, RW, 1, 1, 0},
    {48, 2, RW, 0, 1023, 32},
};
#define ITEM_COUNT (sizeof items / sizeof items[0])

static uint8_t table[TABLE_SIZE];
static uint8_t registered[TABLE_SIZE + 1u]; /* address, then the data of a REG_WRITE */
static uint8_t registered_len;
static bool goal_written_in_wheel_mode;

static const item_t *item_at(uint8_t addr) {
  for (uint8_t i = 0; i < ITEM_COUNT; i++) {
    if (addr >= items[i].addr && addr < items[i].addr + items[i].size) {
      return &items[i];
    }
  }
  return 0;
}

static uint16_t word_at(const uint8_t *t, uint8_t addr) { return (uint16_t)(t[addr] | t[addr + 1u] << 8); }

static void factory(void) {
  for (uint8_t i = 0; i < ITEM_COUNT; i++) {
    table[items[i].addr] = (uint8_t)items[i].factory;
    if (items[i].size == 2u) {
      table[items[i].addr + 1u] = (uint8_t)(items[i].factory >> 8);
    }
  }
#ifdef FOREIGN_OWN_ITEMS
  table[6] = 0x34; /* its own items where the AX-12 keeps its angle limits */
  table[7] = 0x12;
  table[8] = 0x78;
  table[9] = 0x56;
#endif
  registered_len = 0;
  goal_written_in_wheel_mode = false;
}

static bool wheel_mode(const uint8_t *t) { return word_at(t, A_CW) == 0 && word_at(t, A_CCW) == 0; }

static uint8_t conditions(void) {
#ifdef FOREIGN_OWN_ITEMS
  return 0;
#else
  if (wheel_mode(table)) {
    return goal_written_in_wheel_mode ? ERR_ANGLE : 0;
  }
  const uint16_t goal = word_at(table, A_GOAL);
  return (goal < word_at(table, A_CW) || goal > word_at(table, A_CCW)) ? ERR_ANGLE : 0;
#endif
}

/* Whether writing data at addr is allowed: every byte writable, every item it touches in range
 * afterwards (the whole window or nothing). */
static bool write_allowed(uint8_t addr, const uint8_t *data, uint8_t n) {
  if (n == 0u || addr + n > TABLE_SIZE) {
    return false;
  }
  uint8_t after[TABLE_SIZE]; /* the table as the write would leave it: the range check's */
  for (uint8_t a = 0; a < TABLE_SIZE; a++) {
    after[a] = table[a];
  }
  for (uint8_t k = 0; k < n; k++) {
    after[addr + k] = data[k];
  }
  for (uint8_t k = 0; k < n; k++) {
    const uint8_t a = (uint8_t)(addr + k);
#ifdef FOREIGN_OWN_ITEMS
    if (a >= 6u && a <= 9u) {
      return false;
    }
#endif
    const item_t *it = item_at(a);
    if (!it || it->access != RW) {
#ifdef FOREIGN_RO_HOLE
      if (n > 1u) {
        continue; /* the defect: only a one-byte write is checked for read-only addresses */
      }
#endif
      return false;
    }
#ifdef FOREIGN_NO_RANGE_CHECK
    if (a >= EEPROM_SIZE) {
      continue; /* the defect: any value goes in the RAM area */
    }
#endif
    const uint16_t v = it->size == 2u ? word_at(after, it->addr) : after[it->addr];
    uint16_t max = it->max;
    if (it->addr == A_SPEED && wheel_mode(after)) {
      max = 2047u;
    }
    if (v < it->min || v > max) {
      return false;
    }
  }
  return true;
}

static void apply_write(uint8_t addr, const uint8_t *data, uint8_t n) {
#ifdef FOREIGN_HALF_DROP
  const item_t *it = item_at(addr);
  if (n == 1u && it && it->size == 2u) {
    return; /* the defect: half of a 16-bit item is dropped */
  }
#endif
  for (uint8_t k = 0; k < n; k++) {
    if (addr + k == A_REGISTERED) {
      if (data[k] == 0u) {
        registered_len = 0; /* writing 0 discards a registered write */
        table[A_REGISTERED] = 0;
      }
      continue;
    }
    table[addr + k] = data[k];
  }
  if (addr <= A_GOAL + 1u && addr + n > A_GOAL) {
    goal_written_in_wheel_mode = wheel_mode(table);
  }
}

/* ---- the UART, the bus direction and the clock ------------------------------------------ */

/* Received bytes with the time each came in (Timer1's 16 bits: the main loop takes them within a
 * wrap), kept by a short RX interrupt (at 2 Mbps a byte leaves 80 cycles); the main loop sleeps
 * while there is none (idle sleep: the emulator then skips the time instead of simulating a
 * busy loop). */
#define RX_RING 64u
static volatile uint8_t rx_bytes[RX_RING];
static volatile uint16_t rx_at[RX_RING];
static volatile uint8_t rx_head, rx_tail;
static volatile uint16_t timer_overflows;

/* Timer1 (0.5 us ticks) extended to 32 bits by its overflows; interrupts off. */
static uint32_t ticks_locked(void) {
  const uint16_t t = TCNT1;
  uint16_t high = timer_overflows;
  if ((TIFR1 & (1u << TOV1)) && t < 0x8000u) {
    high++; /* it wrapped and the overflow is not counted yet */
  }
  return (uint32_t)high << 16 | t;
}

static inline uint32_t now_ticks(void) {
  const uint8_t sreg = SREG;
  cli();
  const uint32_t t = ticks_locked();
  SREG = sreg;
  return t;
}

ISR(TIMER1_OVF_vect) { timer_overflows++; }

ISR(USART_RX_vect) {
  const uint16_t at = TCNT1; /* the byte's stop bit has ended: a reply timed from here is never early */
  const uint8_t b = UDR0;
  const uint8_t head = rx_head;
  const uint8_t next = (uint8_t)((head + 1u) & (RX_RING - 1u));
  if (next != rx_tail) {
    rx_bytes[head] = b;
    rx_at[head] = at;
    rx_head = next;
  }
}

/* The next byte received and when it came (32-bit ticks); sleeps until there is one. */
static uint8_t next_byte(uint32_t *at) {
  for (;;) {
    cli();
    const uint8_t tail = rx_tail;
    if (tail != rx_head) {
      const uint8_t b = rx_bytes[tail];
      const uint32_t now = ticks_locked();
      *at = now - (uint16_t)((uint16_t)now - rx_at[tail]);
      rx_tail = (uint8_t)((tail + 1u) & (RX_RING - 1u));
      sei();
      return b;
    }
    sleep_enable();
    sei(); /* the instruction after SEI runs before any interrupt: no wake-up is lost */
    sleep_cpu();
    sleep_disable();
  }
}

static void uart_baud(uint8_t reg) {
  UBRR0 = reg; /* U2X: 2 Mbps / (reg + 1), the AX-12's formula */
}

static void uart_init(void) {
  DDRD |= (1u << PD2);
  PORTD &= (uint8_t)~(1u << PD2);
  UCSR0A = (1u << U2X0);
  UCSR0C = (1u << UCSZ01) | (1u << UCSZ00);
  UCSR0B = (1u << RXEN0) | (1u << TXEN0) | (1u << RXCIE0);
  uart_baud(1);
  TCCR1A = 0;
  TCCR1B = (1u << CS11); /* 0.5 us ticks */
  TIMSK1 = (1u << TOIE1);
  set_sleep_mode(SLEEP_MODE_IDLE);
  sei();
}

static void send(const uint8_t *bytes, uint8_t n) {
  PORTD |= (1u << PD2);
  UCSR0A |= (1u << TXC0);
  for (uint8_t i = 0; i < n; i++) {
    while (!(UCSR0A & (1u << UDRE0))) {
    }
    UDR0 = bytes[i];
  }
  while (!(UCSR0A & (1u << TXC0))) {
  }
  PORTD &= (uint8_t)~(1u << PD2);
}

/* A status packet from ident, started 2 us x rdt after `end` (the request's last byte). */
static void reply(uint8_t ident, uint8_t error, const uint8_t *params, uint8_t n, uint8_t rdt, uint32_t end) {
  static uint8_t out[TABLE_SIZE + 6u];
  out[0] = 0xFF;
  out[1] = 0xFF;
  out[2] = ident;
  out[3] = (uint8_t)(n + 2u);
  out[4] = error;
  uint8_t sum = (uint8_t)(ident + n + 2u + error);
  for (uint8_t i = 0; i < n; i++) {
    out[5u + i] = params[i];
    sum = (uint8_t)(sum + params[i]);
  }
  out[5u + n] = (uint8_t)~sum;
#ifdef FOREIGN_IGNORE_RDT
  (void)rdt;
  (void)end;
#else
  while (now_ticks() - end < 4ul * rdt) {
  }
#endif
  send(out, (uint8_t)(n + 6u));
}

/* ---- one packet ------------------------------------------------------------------------- */

static void handle(uint8_t ident, uint8_t instruction, const uint8_t *p, uint8_t n, bool checksum_ok, uint32_t end) {
  const uint8_t me = table[A_ID];
  const bool broadcast = ident == BROADCAST;
#ifdef FOREIGN_NO_BROADCAST
  if (broadcast) {
    return;
  }
#endif
  if (ident != me && !broadcast) {
    return;
  }
  const uint8_t level = table[A_SRL];
  const uint8_t rdt = table[A_RDT];
  if (!checksum_ok) {
    if (!broadcast && level == 2u) {
      reply(me, (uint8_t)(ERR_CHECKSUM | conditions()), 0, 0, rdt, end);
    }
    return;
  }
  uint8_t error = 0;
  uint8_t data[TABLE_SIZE];
  uint8_t data_len = 0;
  uint8_t after_baud = 0xFFu;
  bool reset_after = false;
  bool answer = !broadcast && level == 2u;
  switch (instruction) {
  case PING:
    answer = true; /* the 2006 manual: a broadcast PING is answered too */
    if (n != 0u) {
      error = ERR_INSTRUCTION;
    }
    break;
  case READ:
    answer = !broadcast && level >= 1u;
    if (n != 2u) {
      error = ERR_INSTRUCTION;
    } else if (p[1] == 0u || p[0] + p[1] > TABLE_SIZE) {
      error = ERR_RANGE;
    } else {
      for (uint8_t k = 0; k < p[1]; k++) {
        data[k] = table[p[0] + k];
      }
      data_len = p[1];
    }
    break;
  case WRITE:
  case REG_WRITE:
    if (n < 2u) {
      error = ERR_INSTRUCTION;
    } else if (!write_allowed(p[0], p + 1, (uint8_t)(n - 1u))) {
      error = ERR_RANGE;
    } else if (instruction == REG_WRITE) {
      for (uint8_t k = 0; k < n; k++) {
        registered[k] = p[k];
      }
      registered_len = n;
      table[A_REGISTERED] = 1;
    } else {
      const uint8_t baud = table[A_BAUD];
      apply_write(p[0], p + 1, (uint8_t)(n - 1u));
      if (table[A_BAUD] != baud) {
        after_baud = table[A_BAUD];
      }
    }
    break;
  case ACTION:
    if (n != 0u || registered_len == 0u) {
      error = ERR_INSTRUCTION;
    } else if (!write_allowed(registered[0], registered + 1, (uint8_t)(registered_len - 1u))) {
      error = ERR_RANGE;
      registered_len = 0;
      table[A_REGISTERED] = 0;
    } else {
      const uint8_t baud = table[A_BAUD];
      apply_write(registered[0], registered + 1, (uint8_t)(registered_len - 1u));
      registered_len = 0;
      table[A_REGISTERED] = 0;
      if (table[A_BAUD] != baud) {
        after_baud = table[A_BAUD];
      }
    }
    break;
  case RESET:
    if (n != 0u) {
      error = ERR_INSTRUCTION;
    } else {
      reset_after = true;
    }
    break;
  case SYNC_WRITE:
    if (!broadcast) {
      error = ERR_INSTRUCTION; /* broadcast only */
      break;
    }
    answer = false;
    if (n >= 2u && p[1] > 0u && (uint8_t)(n - 2u) % (uint8_t)(p[1] + 1u) == 0u) {
      for (uint8_t at = 2; at < n; at = (uint8_t)(at + p[1] + 1u)) {
        if (p[at] == me && write_allowed(p[0], p + at + 1, p[1])) {
          apply_write(p[0], p + at + 1, p[1]);
        }
      }
    }
    break;
  default:
    error = ERR_INSTRUCTION;
    break;
  }
  if (answer) {
    reply(me, (uint8_t)(error | conditions()), data, error ? 0 : data_len, rdt, end);
  }
  if (reset_after) {
    factory();
    after_baud = table[A_BAUD];
  }
  if (after_baud != 0xFFu) {
    uart_baud(after_baud);
  }
}

int main(void) {
  factory();
  uart_init();
  uint8_t buf[2u + 255u]; /* ID, LENGTH and up to 255 bytes after it */
  uint16_t have = 0;      /* bytes of the packet so far, header included */
  uint8_t need = 0;       /* bytes after LENGTH still to come */
  uint32_t last_byte = 0;
#ifdef FOREIGN_DEAF_MS
  uint32_t deaf_from = 0;
  bool deaf = false;
#endif
  for (;;) {
    uint32_t at;
    const uint8_t b = next_byte(&at);
#ifdef FOREIGN_DEAF_MS
    if (deaf && at - deaf_from < 2000ul * (FOREIGN_DEAF_MS)) {
      continue;
    }
    deaf = false;
#endif
    if (have && at - last_byte > GAP_TICKS) {
      have = 0; /* a partial packet cut by a gap */
    }
    last_byte = at;
    if (have < 2u) {
      have = b == 0xFFu ? (uint16_t)(have + 1u) : 0u;
      continue;
    }
    if (have == 2u) {
      if (b == 0xFFu) {
        continue; /* more header bytes */
      }
      buf[0] = b;
      have = 3;
      continue;
    }
    if (have == 3u) {
#ifdef FOREIGN_DEAF_MS
      if (buf[0] == 0xFDu && b == 0x00u) { /* FF FF FD 00, a Protocol 2.0 header: deaf for a while */
        deaf = true;
        deaf_from = at;
        have = 0;
        continue;
      }
#endif
      if (b < 2u) {
        have = 0;
        continue;
      }
      buf[1] = b;
      need = b;
      have = 4;
      continue;
    }
    buf[have - 2u] = b;
    have++;
    if (--need == 0u) {
      const uint8_t length = buf[1];
      uint8_t sum = 0;
      for (uint16_t i = 0; i < length + 1u; i++) {
        sum = (uint8_t)(sum + buf[i]);
      }
      const bool ok = (uint8_t)(sum + buf[length + 1u]) == 0xFFu; /* ~sum is the checksum */
      handle(buf[0], buf[2], buf + 3, (uint8_t)(length - 2u), ok, at);
      have = 0;
    }
  }
}
