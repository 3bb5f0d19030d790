/* PAGE (docs/bootloader.md "Packets"): one page of the application area erased, programmed
 * with SPM and compared with what the request carried; the answer carries the request's first
 * two parameters back (the address as sent: a flasher tells a late answer from this one's).
 * Reached from the dispatch (boot_serve.S) with the request in the buffer and r25 its
 * LENGTH. */
#include <avr/io.h>

#include "boot_image.h"
#include "boot_layout.h"
#include "boot_protocol.h"

#define BOOT_START (FLASHEND + 1 - BOOT_SECTION_BYTES)
#define PAGE_DATA (BOOT_BUF_PARAMS + BOOT_PAGE_HEAD_BYTES)

  .text

  .global boot_page
boot_page:
  ldi COUNT, BOOT_PAGE_HEAD_BYTES /* the address, still at BOOT_BUF_PARAMS */
  cpi r25, 2 + BOOT_PAGE_HEAD_BYTES + SPM_PAGESIZE
  brne boot_bad
  rcall boot_page_at
  brcc boot_range
  ldi r24, _BV(PGERS) | _BV(SPMEN)
  rcall spm
  ldi r26, PAGE_DATA
  ldi r25, SPM_PAGESIZE / 2
1:
  ld r0, X+
  ld r1, X+
  ldi r24, _BV(SPMEN)           /* into the page buffer at Z */
  rcall spm
  adiw r30, 2
  dec r25
  brne 1b
  clr r1
  rcall boot_page_at
  ldi r24, _BV(PGWRT) | _BV(SPMEN)
  rcall spm
  ldi r24, _BV(RWWSRE) | _BV(SPMEN) /* the application area readable again */
  rcall spm
  ldi r26, PAGE_DATA
  ldi r25, SPM_PAGESIZE
2:
  lpm r0, Z+
  ld r23, X+
  cpse r0, r23
  ldi ERROR, BOOT_ERROR_PROGRAM
  dec r25
  brne 2b
  rjmp boot_answer

/* SPM with SPMCSR = r24, Z as set; returns once SPMEN clears (a page erase or write: about
 * 4 ms). */
spm:
  out _SFR_IO_ADDR(SPMCSR), r24
  spm
1:
  in r24, _SFR_IO_ADDR(SPMCSR)
  sbrc r24, SPMEN
  rjmp 1b
  ret

/* Z = the first byte of the page that holds the address in the request's first two
 * parameters; carry set when that page is in the application area (below the boot section),
 * clear otherwise. */
  .global boot_page_at
boot_page_at:
  ldd r30, Y + BOOT_BUF_PARAMS
  ldd r31, Y + BOOT_BUF_PARAMS + 1
  andi r30, lo8(~(SPM_PAGESIZE - 1))
  cpi r31, hi8(BOOT_START)
  ret
