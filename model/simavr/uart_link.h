/* SPDX-License-Identifier: GPL-3.0-or-later */
/* USART0 of one simulated MCU, connected to the bus through the board's transceiver.
 *
 * simavr 1.6: its own USART timing is replaced where it is wrong for a bus model: it counts
 * 11 bit times per 8N1 byte, announces a byte at the UDR write, raises TXC after every byte
 * and paces RX from the moment a byte is handed to it (docs/emulator.md "simavr 1.6
 * workarounds"). Here:
 * - TX: a transmit buffer and a shift register as on the silicon. A byte written to UDR0
 *   starts on the wire at once when the shift register is idle (UDRE is set again at once),
 *   otherwise when the previous byte's stop bit ends; TXC is raised when the shift register
 *   empties with the buffer empty. The byte reaches the bus only while the direction pin
 *   (PD2) is high; releasing PD2 during a byte cuts it there.
 * - RX: a byte is placed in the receive FIFO and RXC raised at the end of its stop bit
 *   (exact cycle), only while PD2 is low and RXEN is set. The FIFO holds three bytes (two
 *   buffered plus the shift register); a fourth sets DOR and is lost. RXC behaves as a level:
 *   reading UDR0 with bytes left raises it again. A byte the bus marks
 *   BUS_RX_FRAMING_ERROR (noise on a start or stop bit) sets FE0 while it is in UDR0.
 * - simavr's cycles_per_byte is set to 10 bit times when UBRR0L is written, so anything
 *   inside simavr that uses it agrees with the wire.
 * The hooks chain simavr's own register handlers; only the UDR0 write is taken over. */
#ifndef SIM_UART_LINK_H
#define SIM_UART_LINK_H

#include <stdbool.h>
#include <stdint.h>

#include "bus.h"
#include "simavr_patch.h"

struct avr_t;
struct avr_uart_t;

#define UART_LINK_RX_QUEUE 256u
#define UART_LINK_RX_FIFO_DEPTH 3u

/* Someone watching the USART's pins (a trace, servo_trace.h); NULL members are not called.
 * tx: a byte leaves the shift register on TXD, its start bit at `start`, at cycles_per_bit
 * (whether or not the transceiver drives the bus). rx: a byte reaches the transceiver's
 * receiver as the bus hands it to this node (ahead of time, at its finalization: see bus.h),
 * whether or not the USART then takes it. */
typedef struct {
  void (*tx)(void *ctx, uint8_t value, sim_cycles_t start, double cycles_per_bit);
  void (*rx)(void *ctx, const bus_rx_t *rx);
  void *ctx;
} uart_link_observer_t;

typedef struct {
  struct avr_t *avr;
  struct avr_uart_t *uart;
  const uart_link_observer_t *observer; /* uart_link_observe(); NULL: nobody watches */
  bool fast_interrupts; /* uart_link_use_fast_interrupts() */
  bus_t *bus;
  int node;
  uint16_t ubrr; /* latched at the UBRR0L write */
  double cycles_per_bit; /* from ubrr and U2X0, updated when either is written */
  bool driving;  /* PD2 high: the transceiver drives the bus, the receiver is off */
  /* Transmitter. */
  bool shift_busy;
  bool buffer_full;
  uint8_t buffer;
  sim_cycles_t shift_end;
  /* Bytes the bus has finalized for this node, delivered at their end. */
  bus_rx_t rx_queue[UART_LINK_RX_QUEUE];
  unsigned rx_head, rx_count;
  /* Chained simavr handlers. */
  io_write_hook_t ucsra_write, ucsrb_write, ubrrl_write;
  /* Statistics. */
  uint64_t tx_bytes;        /* started on the wire */
  uint64_t tx_undriven;     /* written while PD2 was low: never on the wire */
  uint64_t tx_overflow;     /* written to a full UDR0: lost */
  uint64_t rx_bytes;        /* placed in the FIFO */
  uint64_t rx_overruns;     /* lost to a full FIFO (DOR) */
  uint64_t rx_while_driving;/* arrived while PD2 was high: not received */
  uint64_t rx_disabled;     /* arrived while RXEN was 0 */
  uint64_t rx_late;         /* delivered after its end (should stay 0) */
} uart_link_t;

/* Hooks USART '0' of avr and adds the node to the bus. Returns false when the MCU has no
 * USART '0' or the bus is full. */
bool uart_link_attach(uart_link_t *link, struct avr_t *avr, bus_t *bus, const char *name);

/* observer (NULL: none) watches the link's pins from now on; call between world steps. An
 * unobserved link pays one pointer test per byte it sends, none per byte it receives. */
void uart_link_observe(uart_link_t *link, const uart_link_observer_t *observer);

/* fast: the USART's interrupts are raised and cleared as fast_interrupts.h does it (the same
 * state, fewer calls: for a servo that runs the fast core); else with simavr's calls (the
 * default, and the reference of the differential test). */
void uart_link_use_fast_interrupts(uart_link_t *link, bool fast);

/* The direction pin changed at the avr's current cycle. */
void uart_link_set_driving(uart_link_t *link, bool driving);

/* The MCU was reset (watchdog, or a test): the USART registers are back to their reset
 * values; a byte in the shift register is cut. */
void uart_link_reset(uart_link_t *link);

/* The bit time now, in cycles: 8 (UBRR0 + 1) with U2X0, 16 (UBRR0 + 1) without. */
double uart_link_cycles_per_bit(const uart_link_t *link);

#endif
