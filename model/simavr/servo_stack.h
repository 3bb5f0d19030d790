/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The deepest the firmware's stack has reached, read from the paint the firmware lays over
 * its free RAM at reset (docs/firmware.md). */
#ifndef SIM_SERVO_STACK_H
#define SIM_SERVO_STACK_H

#include <stdint.h>

#include "servo.h"

/* RAMEND - (lowest address above the end of .bss whose byte is not paint_pattern) + 1, in
 * bytes: the deepest the stack has reached since the paint. bss_end is the first free RAM
 * address (the ELF's _end: elf_ram_end_of_statics()). 0 when the paint is untouched. */
unsigned servo_stack_depth(const servo_t *servo, uint16_t bss_end, uint8_t paint_pattern);

#endif
