/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A tiny stand-in bootloader for the emulator's boot and self-programming tests
 * (test/sim/test_boot_flash.c, test/sim/python/test_boot.py): an ATmega328P program linked at
 * the boot section's start (0x7E00, the top 512 B) that, when the page at TEST_PAGE is blank, erases it and
 * writes a pattern with SPM the way a bootloader does (avr-libc's boot.h, polling SPMEN), then
 * turns the USART receiver on (the emulator's "listening") and waits forever.
 *
 * GPIOR0: 0 started, 1 page erased, 2 page written and the RWW section enabled again,
 *         3 the page held the pattern already.
 * GPIOR1: bit 0 RWWSB read 1 after the write, bit 1 RWWSB read 0 after RWWSRE. */
#include <avr/boot.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <stdint.h>

#define TEST_PAGE 0x1000u

int main(void) {
  GPIOR0 = 0;
  GPIOR1 = 0;
  if (pgm_read_byte(TEST_PAGE) == 0xFF) {
    boot_page_erase(TEST_PAGE);
    boot_spm_busy_wait();
    GPIOR0 = 1;
    for (uint16_t i = 0; i < SPM_PAGESIZE; i += 2) {
      boot_page_fill(TEST_PAGE + i, 0x5A00u | i); /* bytes: i, 0x5A */
    }
    boot_page_write(TEST_PAGE);
    boot_spm_busy_wait();
    if (boot_rww_busy()) {
      GPIOR1 |= 1u;
    }
    boot_rww_enable();
    if (!boot_rww_busy()) {
      GPIOR1 |= 2u;
    }
    GPIOR0 = 2;
  } else {
    GPIOR0 = 3;
  }
  UCSR0B = _BV(RXEN0);
  for (;;) {
  }
}
