/* How the application asks for the bootloader (docs/bootloader.md "Entering from the
 * application"): it jumps to the boot section's first word with GPIOR1/GPIOR2 holding these
 * marks, which read 0 after any reset; the bootloader reads and clears them. AVR only. */
#ifndef BOOT_REQUEST_H
#define BOOT_REQUEST_H

#include <avr/io.h>
#include <stdbool.h>

#include "boot_image.h"

#define BOOT_REQUEST_MARK_1 0xB0u
#define BOOT_REQUEST_MARK_2 0x07u

/* The application's side: interrupts off, marks set, into the bootloader. */
__attribute__((noreturn)) static inline void boot_request_enter(void) {
  __asm__ __volatile__("cli" ::: "memory");
  GPIOR1 = BOOT_REQUEST_MARK_1;
  GPIOR2 = BOOT_REQUEST_MARK_2;
  __asm__ __volatile__("ijmp" ::"z"((uint16_t)((FLASHEND + 1ul - BOOT_SECTION_BYTES) / 2u)) : "memory");
  __builtin_unreachable();
}

/* The bootloader's side: whether the application asked; forgets the marks. */
static inline bool boot_request_take(void) {
  const bool requested = GPIOR1 == BOOT_REQUEST_MARK_1 && GPIOR2 == BOOT_REQUEST_MARK_2;
  GPIOR1 = 0;
  GPIOR2 = 0;
  return requested;
}

#endif
