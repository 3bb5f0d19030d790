/* The bootloader on the AVR (docs/bootloader.md): what to do at reset, the USART polled at the
 * servo's baud, flash through SPM. Runs with interrupts off throughout; no vector table
 * (boot_start.S is its reset entry, at the boot section's first word).
 *
 * Board: USART0 on PD0/PD1 with the bus direction on PD2 (high while transmitting); the
 * H-bridge on PD5/PD6 (OC0B/OC0A), held low (the motor coasts) while the bootloader runs. */
#include <avr/boot.h>
#include <avr/eeprom.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <avr/wdt.h>
#include <stdbool.h>
#include <stdint.h>

#include "boot_image.h"
#include "boot_port.h"
#include "boot_protocol.h"
#include "boot_request.h"
#include "ct_items.h"
#include "dxl_image.h"
#include "boot_frame.h"
#include "dxl_table.h"

/* The stock recovery trigger: HASH_COUNT '#' in a row at HASH_BAUD_REGISTER (57 142 bps, the
 * AX-12's "57 600") within HASH_WINDOW_MS of reset. */
#define HASH_BYTE 0x23u
#define HASH_COUNT 2u
#define HASH_WINDOW_MS 30u
#define HASH_BAUD_REGISTER 34u

#define BUS_DIR_BIT PD2
#define MOTOR_PINS (_BV(PD5) | _BV(PD6))

/* Timer1 in CTC mode at clk/8: OCF1A every 2000 counts = 1 ms at 16 MHz. */
#define TIMER1_COUNTS_PER_MS 2000u

#define X_DEFAULT(name, addr, size, acc, acc_a, min, max, def, def_a) DEFAULT_##name = (def),
enum { CT_ITEMS(X_DEFAULT) };
#define ID_MAX 253u

static boot_frame_t frame;
static boot_t boot;
static uint8_t reply[BOOT_REPLY_MAX_BYTES];
static uint16_t now_ms;

uint8_t boot_port_flash_byte(uint16_t address) { return pgm_read_byte(address); }

void boot_port_flash_program(uint16_t page_address, const uint8_t *bytes) {
  wdt_reset();
  boot_page_erase(page_address);
  boot_spm_busy_wait();
  for (uint8_t i = 0; i < SPM_PAGESIZE; i = (uint8_t)(i + 2u)) {
    boot_page_fill(page_address + i, (uint16_t)(bytes[i] | ((uint16_t)bytes[i + 1u] << 8)));
  }
  boot_page_write(page_address);
  boot_spm_busy_wait();
  boot_rww_enable();
}

/* Counts milliseconds from Timer1's compare flag; call more often than once a millisecond
 * (a page's programming, about 8 ms, only slows the count). */
static void count_ms(void) {
  if (TIFR1 & _BV(OCF1A)) {
    TIFR1 = _BV(OCF1A);
    now_ms++;
  }
}

static void uart_start(uint8_t baud_register) {
  UCSR0A = _BV(U2X0);
  UCSR0B = _BV(RXEN0) | _BV(TXEN0);
  UBRR0H = 0;
  UBRR0L = baud_register;
}

/* Sends a status packet: the bus driven and the receiver off (no echo) until the last stop bit. */
static void uart_send(const uint8_t *bytes, uint8_t count) {
  UCSR0B = _BV(TXEN0);
  PORTD |= _BV(BUS_DIR_BIT);
  UCSR0A |= _BV(TXC0); /* writing 1 clears it */
  while (count--) {
    while (!(UCSR0A & _BV(UDRE0))) {
    }
    UDR0 = *bytes++;
  }
  while (!(UCSR0A & _BV(TXC0))) {
  }
  PORTD &= (uint8_t)~_BV(BUS_DIR_BIT);
  UCSR0B = _BV(RXEN0) | _BV(TXEN0);
}

/* True when HASH_COUNT '#' in a row (no framing error between) arrive within HASH_WINDOW_MS. */
static bool hash_seen(void) {
  uart_start(HASH_BAUD_REGISTER);
  uint8_t in_row = 0;
  while (now_ms < HASH_WINDOW_MS) {
    count_ms();
    if (UCSR0A & _BV(RXC0)) {
      const bool framing_error = (UCSR0A & _BV(FE0)) != 0;
      const uint8_t byte = UDR0;
      in_row = (!framing_error && byte == HASH_BYTE) ? (uint8_t)(in_row + 1u) : 0u;
      if (in_row == HASH_COUNT) {
        return true;
      }
    }
  }
  return false;
}

/* The peripherals back as a reset leaves them (the watchdog aside), then the application's
 * reset vector. */
__attribute__((noreturn)) static void start_app(void) {
  UCSR0B = 0;
  UCSR0A = _BV(TXC0);
  UBRR0L = 0;
  TCCR1B = 0;
  OCR1A = 0;
  TCNT1 = 0;
  TIFR1 = 0xFFu;
  DDRD = 0;
  PORTD = 0;
  __asm__ __volatile__("clr r30\n\tclr r31\n\tijmp" ::: "memory");
  __builtin_unreachable();
}

/* ID and Baud Rate from the settings in EEPROM (the newest valid slot), factory defaults
 * without one. */
static void read_settings(uint8_t *id, uint8_t *baud_register) {
  uint8_t image[DXL_IMAGE_BYTES];
  for (uint8_t offset = 0; offset < DXL_IMAGE_BYTES; offset++) {
    image[offset] = eeprom_read_byte((const uint8_t *)(uintptr_t)offset);
  }
  const uint8_t *const settings = dxl_image_settings(image);
  *id = DEFAULT_ID;
  *baud_register = DEFAULT_BAUD_RATE;
  if (settings) {
    if (settings[CT_ADDR_ID] <= ID_MAX) {
      *id = settings[CT_ADDR_ID];
    }
    *baud_register = settings[CT_ADDR_BAUD_RATE];
  }
}

/* One packet's bytes in, its answer out, until GO starts the application. */
__attribute__((noreturn)) static void serve(void) {
  boot_frame_init(&frame);
  for (;;) {
    wdt_reset();
    count_ms();
    dxl_packet_t packet;
    if ((UCSR0A & _BV(RXC0)) && boot_frame_push(&frame, UDR0, now_ms, &packet)) {
      const uint8_t length = boot_handle(&boot, &packet, reply);
      if (length != 0) {
        uart_send(reply, length);
      }
      if (boot.start_app) {
        start_app();
      }
    }
  }
}

int main(void) {
  const bool requested = boot_request_take();
  wdt_enable(WDTO_2S);
  TCCR0A = 0;
  TCCR0B = 0;
  PORTD &= (uint8_t)~(MOTOR_PINS | _BV(BUS_DIR_BIT));
  DDRD |= MOTOR_PINS | _BV(BUS_DIR_BIT);
  TCCR1A = 0;
  OCR1A = TIMER1_COUNTS_PER_MS - 1u;
  TCCR1B = _BV(WGM12) | _BV(CS11);

  uint8_t id;
  uint8_t baud_register;
  read_settings(&id, &baud_register);
  uint8_t entered_by = requested ? BOOT_STATE_BY_REQUEST : 0u;
  if (!requested && hash_seen()) {
    entered_by = BOOT_STATE_BY_HASH;
    baud_register = HASH_BAUD_REGISTER;
  }
  boot_init(&boot, id, entered_by);
  if (entered_by == 0 && boot_app_valid()) {
    start_app();
  }
  uart_start(baud_register);
  serve();
}
