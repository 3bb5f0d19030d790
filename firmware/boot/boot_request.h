/* How the application asks for the bootloader (docs/bootloader.md "Entering from the
 * application"): interrupts off, it jumps to the boot section's second word
 * (boot_requested in boot_entry.S), which skips the '#' window and the application check;
 * every reset starts at the first word. AVR only. */
#ifndef BOOT_REQUEST_H
#define BOOT_REQUEST_H

#include <avr/io.h>

#include "boot_image.h"

/* The boot section's second word, as a word address (what IJMP takes). */
#define BOOT_REQUEST_WORD ((FLASHEND + 1ul - BOOT_SECTION_BYTES) / 2u + 1u)

/* The application's side: interrupts off, r1 = 0 (the C ABI's), into the bootloader. */
__attribute__((noreturn)) static inline void boot_request_enter(void) {
  __asm__ __volatile__("cli\n\tijmp" ::"z"((uint16_t)BOOT_REQUEST_WORD) : "memory");
  __builtin_unreachable();
}

#endif
