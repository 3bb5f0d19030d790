/* The bootloader from reset to serving (docs/bootloader.md "At reset"): the two ways in, the
 * stock '#' window, the application's check and start, the settings. Assembly for the 512 B
 * boot section; interrupts stay off throughout; no vector table (BOOTRST makes every reset
 * start at boot_reset, the boot section's first word).
 *
 * Board (docs/hardware.md): USART0 on PD0/PD1, the bus direction on PD2 (high while this
 * servo transmits), the H-bridge on PD5/PD6 (both low: the motor coasts). */
#include <avr/io.h>

#include "boot_image.h"
#include "boot_layout.h"

#define BOOT_START (FLASHEND + 1 - BOOT_SECTION_BYTES)
#define RECORD_AT (BOOT_START - BOOT_RECORD_BYTES)

#if (BOOT_START & 0xFF) != 0 || (RAMSTART & 0xFF) != 0
#error "the boot section and RAMSTART must start on a 256-byte boundary"
#endif
#if BOOT_DEFAULT_ID != BOOT_DEFAULT_BAUD
#error "settings: one register value for the factory ID and Baud Rate"
#endif

  .text

/* Word 0: every reset. */
  .global boot_reset
boot_reset:
  rjmp power_up

/* Word 1: the application's way in (boot_request.h): it jumps here with interrupts off and
 * r1 = 0. The '#' window and the application check are skipped: the bootloader stays. */
  .global boot_requested
boot_requested:
  set
  rjmp init

power_up:
  clr r1
  clt                           /* SREG is 0 after a reset; T says "entered on request" */
init:
  out _SFR_IO_ADDR(TCCR0A), r1  /* Timer0's outputs off (an application may leave them on) */
  ldi r24, _BV(PD0)
  out _SFR_IO_ADDR(PORTD), r24  /* RXD pulled up while the transceiver's receiver is off */
  ldi r24, _BV(PD2) | _BV(PD5) | _BV(PD6)
  out _SFR_IO_ADDR(DDRD), r24   /* bus direction and H-bridge low: listening, coasting */
  clr r28
  ldi r29, hi8(RAMSTART)        /* Y: the buffer */
  ldi TXC_CLEAR, _BV(TXC0) | _BV(U2X0)
  sts UCSR0A, TXC_CLEAR
  ldi r24, _BV(RXEN0) | _BV(TXEN0)
  sts UCSR0B, r24
  brts requested

/* Power-up: BOOT_HASH_COUNT '#' in a row (no framing error) at BOOT_HASH_BAUD before Timer1
 * at clk/8 first overflows (32.8 ms) keep the bootloader, at that baud. */
  ldi r24, BOOT_HASH_BAUD
  sts UBRR0L, r24
  ldi r24, _BV(CS11)
  sts TCCR1B, r24
hash_restart:
  ldi r17, BOOT_HASH_COUNT
hash_wait:
  wdr
  lds r24, UCSR0A
  sbrs r24, RXC0
  rjmp 1f
  lds r25, UDR0
  sbrc r24, FE0
  rjmp hash_restart
  cpi r25, BOOT_HASH_BYTE
  brne hash_restart
  dec r17
  breq hash_seen
1:
  sbis _SFR_IO_ADDR(TIFR1), TOV1
  rjmp hash_wait

/* The application is valid when its record names an image below the record and the image's
 * Fletcher-16 matches (boot_image.h); then it starts with the chip as the bootloader leaves
 * it (the application sets up every peripheral it uses: UART, Timer1, PORTD, the watchdog).
 * GO comes here too. About 9 cycles a byte: 4.3 ms for a 7.6 KB image. */
  .global boot_check_app
boot_check_app:
  ldi r30, lo8(RECORD_AT)
  ldi r31, hi8(RECORD_AT)
  lpm r26, Z+                   /* X: the image's last address */
  lpm r27, Z+
  lpm r18, Z+                   /* r19:r18: its check value */
  lpm r19, Z+
  cpi r27, hi8(BOOT_START)
  brsh settings
  clr r30
  clr r31
  movw r24, r30                 /* r24 sum1, r25 sum2 */
1:
  wdr
  lpm r0, Z+
  add r24, r0
  add r25, r24
  sbiw r26, 1
  brcc 1b
  cp r24, r18
  cpc r25, r19
  brne settings
  clr r30
  clr r31
  ijmp

hash_seen:
  set                           /* stay at BOOT_HASH_BAUD */
  rjmp settings
requested:
  clt

/* Staying: ID and Baud Rate from the slot with the newer sequence number (the firmware writes
 * a slot's sequence number last, so that slot is whole), the factory ID and Baud Rate when
 * its ID is no servo's (a blank EEPROM). */
settings:
  movw r26, r28
  out _SFR_IO_ADDR(EEARH), r1
1:
  out _SFR_IO_ADDR(EEARL), r26  /* XL: the EEPROM address, as the buffer starts at 0x..00 */
  sbi _SFR_IO_ADDR(EECR), EERE
  in r0, _SFR_IO_ADDR(EEDR)
  st X+, r0
  cpi r26, BOOT_EEPROM_IMAGE_BYTES
  brne 1b
  ldd r24, Y + BOOT_EEPROM_SLOT_STRIDE + BOOT_EEPROM_SLOT_SEQUENCE
  ldd r25, Y + BOOT_EEPROM_SLOT_SEQUENCE
  movw r30, r28
  sub r24, r25
  breq 2f
  brmi 2f                       /* the second slot's ahead by 1..127: it is newer */
  adiw r30, BOOT_EEPROM_SLOT_STRIDE
2:
  ldd r24, Z + BOOT_EEPROM_SLOT_ID
  ldd BAUD, Z + BOOT_EEPROM_SLOT_BAUD
  cpi r24, 0xFE
  brlo 3f
  ldi r24, BOOT_DEFAULT_ID
  mov BAUD, r24                 /* BOOT_DEFAULT_BAUD */
3:
  mov ID, r24
  clr FRAME_STATE
  brts 4f
  sts UBRR0L, BAUD
4:
  ldi r24, _BV(CS11) | _BV(CS10)
  sts TCCR1B, r24               /* Timer1 at clk/64: the gap rule (boot_serve.S) */
  rjmp boot_serve
