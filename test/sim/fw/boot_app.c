/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A stand-in application for the boot tests (test/sim/test_boot_flash.c): built twice, with
 * APP_MARK 1 and 2, as two builds of one application whose flash bytes differ. Build 2 also
 * tries to write the page at 0x1000 with SPM from the application section, which silicon
 * (and the emulator) ignores; GPIOR0 = 1 once it has tried. */
#include <avr/boot.h>
#include <avr/io.h>

int main(void) {
  GPIOR2 = APP_MARK;
#if APP_MARK == 2
  for (uint16_t i = 0; i < SPM_PAGESIZE; i += 2) {
    boot_page_fill(0x1000u + i, 0x1234u);
  }
  boot_page_write(0x1000u);
  boot_spm_busy_wait();
  GPIOR0 = 1;
#endif
  for (;;) {
  }
}
