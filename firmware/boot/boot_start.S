/* The bootloader's reset entry, the first word of the boot section (BOOTRST makes every reset
 * start here; the application jumps here to ask for the bootloader). No vector table: the
 * bootloader never enables interrupts. Sets what crt1 would (r1 = 0, interrupts off, SP at
 * RAMEND: the application may have jumped here with its own stack), then libgcc's .init4
 * clears .bss and copies .data, and .init9 enters main, which never returns. */
#include <avr/io.h>

  .section .init0, "ax", @progbits
  .global __boot_entry
__boot_entry:
  cli
  clr r1
  out _SFR_IO_ADDR(SREG), r1
  ldi r28, lo8(RAMEND)
  ldi r29, hi8(RAMEND)
  out _SFR_IO_ADDR(SPH), r29
  out _SFR_IO_ADDR(SPL), r28

  .section .init9, "ax", @progbits
  rjmp main
