/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A tiny AVR program that exercises the simulated board without the real firmware: the
 * tests of the wire model (test/sim/test_wire.c) run it. Interrupt-driven USART at
 * 2 000 000 / (UBRR0 + 1) bit/s with U2X, direction pin PD2 raised for each reply and
 * released in the TX-complete interrupt, as docs/hardware.md asks of the firmware.
 *
 * Each received byte b is answered at once:
 *   0x00..0x7F  b, b + 1 (two bytes back to back)
 *   0x80..0x8F  b, then UBRR0 = b & 0x0F once the reply has left
 *   0x90..0x9F  EEPROM[b & 0x0F] += 1, answered with the new value
 *   0xA0        40 bytes 0..39
 *   0xB0..0xB2  ADC channel b & 3: low byte, high byte
 *   0xC0        no answer; interrupts off for 60 us (the USART must hold what arrives)
 *   0xD0        answers 1 byte with PD2 left low (must never reach the wire)
 *   0xE0        answers 0xE0, 0xE1 but releases PD2 right after writing the second byte
 * The LED (PB5) toggles for each byte; OCR0A follows the last byte, OCR0B its complement. */
#include <avr/eeprom.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>
#include <util/delay.h>

static volatile uint8_t rx_buf[32];
static volatile uint8_t rx_head, rx_tail;
static volatile uint8_t tx_buf[48];
static volatile uint8_t tx_len, tx_pos;
static volatile uint8_t tx_busy;
static volatile uint8_t pending_ubrr = 0xFF;
static volatile uint8_t release_early;

ISR(USART_RX_vect) {
  rx_buf[rx_head & 31u] = UDR0;
  rx_head++;
}

ISR(USART_UDRE_vect) {
  UDR0 = tx_buf[tx_pos++];
  if (tx_pos == tx_len) {
    UCSR0B = (uint8_t)((UCSR0B & ~_BV(UDRIE0)) | _BV(TXCIE0));
    if (release_early) {
      PORTD &= (uint8_t)~_BV(PD2);
    }
  }
}

ISR(USART_TX_vect) {
  PORTD &= (uint8_t)~_BV(PD2);
  UCSR0B &= (uint8_t)~_BV(TXCIE0);
  if (pending_ubrr != 0xFF) {
    UBRR0H = 0;
    UBRR0L = pending_ubrr;
    pending_ubrr = 0xFF;
  }
  tx_busy = 0;
}

static void reply(uint8_t n, uint8_t drive) {
  while (tx_busy) {
  }
  tx_len = n;
  tx_pos = 0;
  tx_busy = 1;
  if (drive) {
    PORTD |= _BV(PD2);
  }
  UCSR0A |= _BV(TXC0);
  UCSR0B |= _BV(UDRIE0);
}

static uint16_t adc_read(uint8_t channel) {
  ADMUX = (uint8_t)(_BV(REFS0) | channel);
  ADCSRA |= _BV(ADSC);
  while (ADCSRA & _BV(ADSC)) {
  }
  return ADC;
}

int main(void) {
  DDRD |= _BV(PD2);
  DDRB |= _BV(PB5);
  DDRD |= _BV(PD6) | _BV(PD5);
  TCCR0A = _BV(COM0A1) | _BV(COM0B1) | _BV(WGM01) | _BV(WGM00);
  TCCR0B = _BV(CS00);
  ADCSRA = _BV(ADEN) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0);
  UBRR0H = 0;
  UCSR0A = _BV(U2X0);
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
  UBRR0L = 1;
  UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
  sei();
  for (;;) {
    cli();
    if (rx_head == rx_tail && !tx_busy) {
      sleep_enable();
      sei();
      sleep_cpu();
      sleep_disable();
    }
    sei();
    if (rx_head == rx_tail) {
      continue;
    }
    const uint8_t b = rx_buf[rx_tail & 31u];
    rx_tail++;
    PORTB ^= _BV(PB5);
    OCR0A = b;
    OCR0B = (uint8_t)~b;
    while (tx_busy) {
    }
    release_early = 0;
    if (b < 0x80) {
      tx_buf[0] = b;
      tx_buf[1] = (uint8_t)(b + 1u);
      reply(2, 1);
    } else if (b < 0x90) {
      tx_buf[0] = b;
      pending_ubrr = b & 0x0Fu;
      reply(1, 1);
    } else if (b < 0xA0) {
      uint8_t *addr = (uint8_t *)(uintptr_t)(b & 0x0Fu);
      const uint8_t v = (uint8_t)(eeprom_read_byte(addr) + 1u);
      eeprom_write_byte(addr, v);
      eeprom_busy_wait();
      tx_buf[0] = v;
      reply(1, 1);
    } else if (b == 0xA0) {
      for (uint8_t i = 0; i < 40; i++) {
        tx_buf[i] = i;
      }
      reply(40, 1);
    } else if (b >= 0xB0 && b <= 0xB2) {
      const uint16_t v = adc_read(b & 3u);
      tx_buf[0] = (uint8_t)v;
      tx_buf[1] = (uint8_t)(v >> 8);
      reply(2, 1);
    } else if (b == 0xC0) {
      cli();
      _delay_us(60);
      sei();
    } else if (b == 0xD0) {
      tx_buf[0] = 0xD0;
      reply(1, 0);
    } else if (b == 0xE0) {
      tx_buf[0] = 0xE0;
      tx_buf[1] = 0xE1;
      release_early = 1;
      reply(2, 1);
    }
  }
}
