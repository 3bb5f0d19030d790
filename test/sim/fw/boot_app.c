/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A stand-in application for the boot tests (test/sim/test_boot_flash.c): built twice, with
 * APP_MARK 1 and 2, as two builds of one application whose flash bytes differ. */
#include <avr/io.h>

int main(void) {
  GPIOR2 = APP_MARK;
  for (;;) {
  }
}
