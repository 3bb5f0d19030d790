/* The bootloader's packets (docs/bootloader.md "Packets"): bytes from the bus framed into
 * requests, requests to this servo's ID answered, until GO starts a valid application.
 * Polled USART, interrupts off. Register and buffer conventions: boot_layout.h. */
#include <avr/io.h>

#include "boot_image.h"
#include "boot_layout.h"
#include "boot_protocol.h"

/* A gap of more than 100 ms between two bytes drops a partial packet: Timer1 at clk/64
 * (4 us) is set this far below its overflow at every byte, so TOV1 marks the gap. */
#if F_CPU != 16000000
#error "the gap's ticks are for 16 MHz"
#endif
#define GAP_TICKS 25000
#define GAP_PRESET (0x10000 - GAP_TICKS)

  .text

  .global boot_answer
boot_answer:
  rcall reply
  .global boot_serve
boot_serve:
  wdr
  lds r24, UCSR0A
  sbrs r24, RXC0
  rjmp boot_serve
  lds r24, UDR0
  sbic _SFR_IO_ADDR(TIFR1), TOV1
  clr FRAME_STATE
  ldi r25, hi8(GAP_PRESET)
  sts TCNT1H, r25
  ldi r25, lo8(GAP_PRESET)
  sts TCNT1L, r25
  sbi _SFR_IO_ADDR(TIFR1), TOV1

/* The framing step (docs/policy.md "Framing and bus"): two or more 0xFF, ID, LENGTH (2 or
 * more), LENGTH - 1 bytes of instruction and parameters, checksum = ~(ID + LENGTH + body).
 * FRAME_STATE: 0 and 1 count the 0xFF of a header, 2 waits for the ID past any further 0xFF,
 * 3 stores ID, LENGTH and body at Z (from BOOT_BUF_ID on: 257 B at most) and sums them in
 * FRAME_SUM. A LENGTH below 2 ends the header there; a packet's bytes are never searched
 * again, whatever its checksum, and the search starts after them. A packet with a good
 * checksum to this servo's ID goes on to the dispatch. Unlike the core's step, the bytes of a
 * Protocol 2.0 frame are searched too (no room to pass over them). */
  cpi FRAME_STATE, 3
  breq 2f
  cpi r24, 0xFF
  brne 1f
  cpi FRAME_STATE, 2
  adc FRAME_STATE, r1           /* 0 -> 1 -> 2, and 2 stays */
  st Y, r24                     /* the status packet's header, FF FF */
  std Y + BOOT_BUF_HEADER + 1, r24
  rjmp boot_serve
1:
  cpi FRAME_STATE, 2
  ldi FRAME_STATE, 0
  brne boot_serve
  movw r30, r28
  adiw r30, BOOT_BUF_ID         /* Z: where the packet goes (a long one runs past 0x..FF) */
  clr FRAME_SUM
  ldi FRAME_STATE, 3
2:
  st Z+, r24
  add FRAME_SUM, r24
  cpi r30, BOOT_BUF_LENGTH + 1
  brlo boot_serve               /* the ID */
  brne 3f
  mov FRAME_LEFT, r24           /* LENGTH */
  cpi r24, 2
  brsh boot_serve
  ldi FRAME_LEFT, 1             /* below 2: it ends here, and ID + LENGTH is no good sum */
3:
  dec FRAME_LEFT
  brne boot_serve
  clr FRAME_STATE
  cpi FRAME_SUM, 0xFF
  brne boot_serve
  ldd r24, Y + BOOT_BUF_ID
  cp r24, ID
  brne boot_serve

/* Dispatch: the status packet's error and parameter count start at 0. */
  ldd r24, Y + BOOT_BUF_INSTRUCTION
  ldd r25, Y + BOOT_BUF_LENGTH
  clr ERROR
  clr COUNT
  cpi r24, BOOT_INST_PING
  breq boot_answer
  cpi r24, BOOT_INST_ENTER
  breq boot_answer
  cpi r24, BOOT_INST_PAGE
  breq boot_page
  cpi r24, BOOT_INST_READ
  breq read
  cpi r24, BOOT_INST_INFO
  breq info
  cpi r24, BOOT_INST_GO
  breq go
  .global boot_bad
boot_bad:
  ldi ERROR, BOOT_ERROR_INSTRUCTION
  rjmp boot_answer
  .global boot_range
boot_range:
  ldi ERROR, BOOT_ERROR_RANGE
  rjmp boot_answer

/* GO: answered, then the application's check (boot_entry.S) starts it, or the bootloader
 * goes on serving when it is not valid. */
go:
  rcall reply
  rjmp boot_check_app

/* READ: a page of the application area (its address, 16 bits). */
read:
  cpi r25, 2 + 2
  brne boot_bad
  rcall boot_page_at
  brcc boot_range
  ldi COUNT, SPM_PAGESIZE
  rjmp copy

/* INFO: BOOT_VERSION and the signature. */
info:
  ldi r30, lo8(info_table)
  ldi r31, hi8(info_table)
  ldi COUNT, BOOT_INFO_BYTES
copy:
  ldi r26, BOOT_BUF_PARAMS
  mov r25, COUNT
1:
  lpm r0, Z+
  st X+, r0
  dec r25
  brne 1b
  rjmp boot_answer

/* The status packet: FF FF ID LENGTH ERROR, COUNT parameters already at BOOT_BUF_PARAMS, the
 * checksum; the bus driven by PD2 from before the first start bit to after the last stop
 * bit, one byte at a time (TXC). The receiver stays on: the transceiver's receiver is off
 * while PD2 is high, and PD0's pull-up holds RXD idle meanwhile. */
reply:
  sbi _SFR_IO_ADDR(PORTD), PD2
  subi COUNT, -2
  std Y + BOOT_BUF_LENGTH, COUNT
  std Y + BOOT_BUF_INSTRUCTION, ERROR
  subi COUNT, -4                /* bytes to send: LENGTH + 4 */
  clr r26
  ldi r23, 2                    /* the sum: 0xFF + 0xFF + 2 wraps to 0 */
1:
  cpi COUNT, 1
  brne 2f
  com r23                       /* the checksum, last */
  st X, r23
2:
  ld r24, X+
  add r23, r24
  wdr
  sts UDR0, r24
3:
  lds r25, UCSR0A
  sbrs r25, TXC0
  rjmp 3b
  sts UCSR0A, TXC_CLEAR
  dec COUNT
  brne 1b
  cbi _SFR_IO_ADDR(PORTD), PD2
  ret

info_table:
  .byte BOOT_VERSION, SIGNATURE_0, SIGNATURE_1, SIGNATURE_2
