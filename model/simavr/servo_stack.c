/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "servo_stack.h"

#include <sim_avr.h>

unsigned servo_stack_depth(const servo_t *servo, uint16_t bss_end, uint8_t paint_pattern) {
  const avr_t *avr = servo->avr;
  const unsigned ramend = avr->ramend;
  for (unsigned addr = bss_end; addr <= ramend; addr++) {
    if (avr->data[addr] != paint_pattern) {
      return ramend - addr + 1u;
    }
  }
  return 0;
}
