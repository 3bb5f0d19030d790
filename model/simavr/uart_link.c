/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "uart_link.h"

#include <string.h>

#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_io.h>

#include "fast_interrupts.h"

DEFINE_FIFO(uint16_t, uart_fifo);

static avr_uart_t *find_uart0(avr_t *avr) {
  for (avr_io_t *io = avr->io_port; io; io = io->next) {
    if (io->kind && strcmp(io->kind, "uart") == 0 && io->irq_ioctl_get == (uint32_t)AVR_IOCTL_UART_GETIRQ('0')) {
      return (avr_uart_t *)io;
    }
  }
  return NULL;
}

double uart_link_cycles_per_bit(const uart_link_t *link) { return link->cycles_per_bit; }

static void update_baud(uart_link_t *link) {
  const double per_count = avr_regbit_get(link->avr, link->uart->u2x) ? 8.0 : 16.0;
  const double cpb = per_count * ((double)link->ubrr + 1.0);
  if (cpb != link->cycles_per_bit) {
    link->cycles_per_bit = cpb;
    /* simavr 1.6 counts 11 bit times per 8N1 byte: give its USART the wire's 10. */
    link->uart->cycles_per_byte = (avr_cycle_count_t)(cpb * BUS_FRAME_BITS_8N1);
    if (link->node >= 0) {
      bus_baud_changed(link->bus);
    }
  }
}

static double node_cycles_per_bit(void *ctx) { return uart_link_cycles_per_bit((const uart_link_t *)ctx); }

static sim_cycles_t frame_cycles(const uart_link_t *link) {
  return (sim_cycles_t)(uart_link_cycles_per_bit(link) * BUS_FRAME_BITS_8N1);
}

/* The USART's interrupts: simavr's calls, or the same without the calls nobody needs
 * (fast_interrupts.h) when the servo runs the fast core. */
static void raise_interrupt(const uart_link_t *link, avr_int_vector_t *vector) {
  simavr_interrupts_make_room(link->avr); /* room in simavr's pending list (simavr_patch.h) */
  if (link->fast_interrupts) {
    (void)fast_raise_interrupt(link->avr, vector);
  } else {
    (void)avr_raise_interrupt(link->avr, vector);
  }
}

static void clear_bit(const uart_link_t *link, avr_regbit_t rb) {
  if (link->fast_interrupts) {
    fast_regbit_clear(link->avr, rb);
  } else {
    avr_regbit_clear(link->avr, rb);
  }
}

/* simavr 1.6: UDRE and RXC are "sticky": avr_clear_interrupt leaves their flag set. */
static void clear_flag(const uart_link_t *link, avr_int_vector_t *vector) {
  if (link->fast_interrupts) {
    fast_clear_interrupt(link->avr, vector);
  } else {
    avr_clear_interrupt(link->avr, vector);
  }
  clear_bit(link, vector->raised);
}

/* ---- transmitter ---- */

static void start_byte(uart_link_t *link, uint8_t value, sim_cycles_t at) {
  link->shift_busy = true;
  if (__builtin_expect(link->observer != NULL, 0) && link->observer->tx) {
    link->observer->tx(link->observer->ctx, value, at, link->cycles_per_bit);
  }
  if (link->driving) {
    link->shift_end = bus_send(link->bus, link->node, value, at);
    link->tx_bytes++;
  } else {
    link->shift_end = at + frame_cycles(link);
    link->tx_undriven++;
  }
}

static avr_cycle_count_t shift_done(avr_t *avr, avr_cycle_count_t when, void *param) {
  (void)avr;
  uart_link_t *link = param;
  if (link->buffer_full) {
    link->buffer_full = false;
    start_byte(link, link->buffer, when);
    raise_interrupt(link, &link->uart->udrc);
    return link->shift_end;
  }
  link->shift_busy = false;
  raise_interrupt(link, &link->uart->txc);
  return 0;
}

static void udr_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param) {
  (void)addr;
  uart_link_t *link = param;
  if (!avr_regbit_get(avr, link->uart->txen)) {
    return;
  }
  if (!link->shift_busy) {
    start_byte(link, v, avr->cycle);
    avr_cycle_timer_register(avr, link->shift_end - avr->cycle, shift_done, link);
    /* The buffer moved to the shift register: empty again. */
    raise_interrupt(link, &link->uart->udrc);
  } else if (!link->buffer_full) {
    link->buffer = v;
    link->buffer_full = true;
    clear_flag(link, &link->uart->udrc);
  } else {
    link->tx_overflow++;
  }
}

static void ucsrb_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param) {
  uart_link_t *link = param;
  avr_uart_t *u = link->uart;
  io_hook_chain(&link->ucsrb_write, avr, addr, v);
  /* simavr 1.6 raises UDRE when UDRIE is set and its own (unused) TX pump is idle, even with
   * a byte waiting in the buffer. */
  if (link->buffer_full) {
    clear_flag(link, &link->uart->udrc);
  }
  /* simavr 1.6 workaround: it marks an interrupt pending only when its flag rises while it is
   * enabled; on silicon RXC and TXC are levels, and enabling RXCIE or TXCIE with the flag set
   * interrupts at once (a received byte waiting when an application takes over the USART a
   * bootloader left receiving). */
  if (avr_regbit_get(avr, u->rxc.enable) && avr_regbit_get(avr, u->rxc.raised)) {
    raise_interrupt(link, &u->rxc);
  }
  if (avr_regbit_get(avr, u->txc.enable) && avr_regbit_get(avr, u->txc.raised)) {
    raise_interrupt(link, &u->txc);
  }
}

static void ubrrl_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param) {
  uart_link_t *link = param;
  io_hook_chain(&link->ubrrl_write, avr, addr, v);
  link->ubrr = (uint16_t)((avr->data[link->uart->ubrrl.reg] | (avr->data[link->uart->ubrrh.reg] << 8)) & 0x0FFFu);
  update_baud(link);
}

static void ucsra_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param) {
  uart_link_t *link = param;
  io_hook_chain(&link->ucsra_write, avr, addr, v);
  update_baud(link); /* U2X0 */
}

/* ---- receiver ---- */

/* simavr 1.6 workaround (speed): UDR0 and UCSR0A reads, in place of simavr's (avr_uart_read,
 * avr_uart_status_read), with the same effect on what the firmware sees, for a fraction of
 * the host work (they run for every byte every servo hears): simavr's also cancel a receive
 * timer this link never starts (receive() fills the FIFO itself) and raise XON/XOFF IRQs
 * nothing listens to.
 * UDR0 pops the FIFO's head (0 with the receiver off or nothing received); the last byte
 * taken clears RXC0, a byte still waiting keeps the interrupt raised (RXC is a level); DOR0
 * clears once the FIFO has room. */
static uint8_t udr_read(avr_t *avr, avr_io_addr_t addr, void *param) {
  (void)addr;
  uart_link_t *link = param;
  avr_uart_t *u = link->uart;
  uint8_t v = 0;
  if (avr_regbit_get(avr, u->rxen) && avr_regbit_get(avr, u->rxc.raised) && !uart_fifo_isempty(&u->input)) {
    v = (uint8_t)uart_fifo_read(&u->input);
  }
  if (uart_fifo_isempty(&u->input)) {
    clear_flag(link, &u->rxc);
  } else {
    raise_interrupt(link, &u->rxc);
  }
  if (!uart_fifo_isfull(&u->input)) {
    clear_bit(link, u->dor);
  }
  return v;
}

/* UCSR0A: FE0 describes the byte at the FIFO's head, as on silicon. */
static uint8_t ucsra_read(avr_t *avr, avr_io_addr_t addr, void *param) {
  uart_link_t *link = param;
  avr_uart_t *u = link->uart;
  uint8_t v = avr->data[addr];
  if (!uart_fifo_isempty(&u->input)) {
    const uint8_t fe_mask = (uint8_t)(u->fe.mask << u->fe.bit);
    v = (uart_fifo_read_at(&u->input, 0) & UART_INPUT_FE) ? (uint8_t)(v | fe_mask) : (uint8_t)(v & ~fe_mask);
  }
  return v;
}

/* A receive FIFO entry: the byte, plus simavr's UART_INPUT_FE for a framing error, which
 * simavr shows as FE0 in UCSR0A while that byte is at the head of the FIFO (as on silicon:
 * FE0 describes the byte in UDR0; the data bits are delivered). */
static uint16_t fifo_entry(const bus_rx_t *rx) {
  return (uint16_t)(rx->value | ((rx->flags & BUS_RX_FRAMING_ERROR) ? UART_INPUT_FE : 0u));
}

/* simavr 1.6 paces a received byte by its own byte time from the moment it is handed over;
 * here the bus hands it over at the end of its stop bit (rx_due), and it enters the FIFO at
 * once, or sets DOR when the FIFO's three places are taken. */
static void receive(uart_link_t *link, const bus_rx_t *rx) {
  avr_t *avr = link->avr;
  avr_uart_t *u = link->uart;
  if (link->driving) {
    link->rx_while_driving++;
    return;
  }
  if (!avr_regbit_get(avr, u->rxen)) {
    link->rx_disabled++;
    return;
  }
  if (uart_fifo_get_read_size(&u->input) >= UART_LINK_RX_FIFO_DEPTH) {
    avr_regbit_set(avr, u->dor);
    link->rx_overruns++;
    return;
  }
  uart_fifo_write(&u->input, fifo_entry(rx));
  simavr_uart_rx_limiter_reset(u); /* simavr 1.6: else its limiter clears RXC early */
  link->rx_bytes++;
  raise_interrupt(link, &u->rxc);
}

static avr_cycle_count_t rx_due(avr_t *avr, avr_cycle_count_t when, void *param) {
  (void)when;
  uart_link_t *link = param;
  while (link->rx_count) {
    const bus_rx_t *rx = &link->rx_queue[link->rx_head];
    if (rx->end > avr->cycle) {
      return rx->end;
    }
    receive(link, rx);
    link->rx_head = (link->rx_head + 1u) % UART_LINK_RX_QUEUE;
    link->rx_count--;
  }
  return 0;
}

static void arm_rx(uart_link_t *link) {
  if (link->rx_count == 0) {
    return;
  }
  const sim_cycles_t first = link->rx_queue[link->rx_head].end;
  const sim_cycles_t now = link->avr->cycle;
  avr_cycle_timer_register(link->avr, first > now ? first - now : 0, rx_due, link);
}

static void node_deliver(void *ctx, const bus_rx_t *rx) {
  uart_link_t *link = ctx;
  if (link->rx_count == UART_LINK_RX_QUEUE) {
    link->rx_overruns++;
    return;
  }
  if (rx->end < link->avr->cycle) {
    link->rx_late++;
  }
  link->rx_queue[(link->rx_head + link->rx_count) % UART_LINK_RX_QUEUE] = *rx;
  link->rx_count++;
  if (link->rx_count == 1u) {
    arm_rx(link);
  }
}

/* ---- set-up ---- */

/* node_deliver with the observer told first (uart_link_observe), so that an unobserved link
 * pays nothing for it. */
static void node_deliver_observed(void *ctx, const bus_rx_t *rx) {
  const uart_link_t *link = ctx;
  if (link->observer && link->observer->rx) {
    link->observer->rx(link->observer->ctx, rx);
  }
  node_deliver(ctx, rx);
}

void uart_link_observe(uart_link_t *link, const uart_link_observer_t *observer) {
  link->observer = observer;
  bus_set_node_deliver(link->bus, link->node, observer ? node_deliver_observed : node_deliver);
}

bool uart_link_attach(uart_link_t *link, avr_t *avr, bus_t *bus, const char *name) {
  memset(link, 0, sizeof(*link));
  link->avr = avr;
  link->bus = bus;
  link->uart = find_uart0(avr);
  if (!link->uart) {
    return false;
  }
  avr_uart_t *u = link->uart;
  uint32_t flags = 0; /* simavr 1.6: no POLL_SLEEP (400x slower polling), no STDIO echo */
  avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);

  /* simavr 1.6: UDR0 write taken over (simavr's pump would time bytes at 11 bits, from the
   * write, and raise TXC after every byte). */
  io_take_write(avr, u->r_udr, udr_write, link);
  /* UDR0 and UCSR0A reads: taken over (udr_read, ucsra_read). */
  io_take_read(avr, u->r_udr, udr_read, link);
  if (u->fe.reg != u->r_ucsra || !io_has_read(avr, u->r_ucsra)) {
    return false; /* not the simavr 1.6 layout this replaces */
  }
  io_take_read(avr, u->r_ucsra, ucsra_read, link);
  io_hook_write(avr, u->r_ucsra, ucsra_write, link, &link->ucsra_write);
  io_hook_write(avr, u->r_ucsrb, ucsrb_write, link, &link->ucsrb_write);
  io_hook_write(avr, u->ubrrl.reg, ubrrl_write, link, &link->ubrrl_write);
  if (!link->ucsra_write.c || !link->ucsrb_write.c || !link->ubrrl_write.c) {
    return false;
  }
  link->node = -1;
  update_baud(link);
  const bus_node_ops_t ops = {.cycles_per_bit = node_cycles_per_bit, .deliver = node_deliver, .ctx = link};
  link->node = bus_add_node(bus, name, &ops);
  return link->node >= 0;
}

void uart_link_use_fast_interrupts(uart_link_t *link, bool fast) { link->fast_interrupts = fast; }

void uart_link_set_driving(uart_link_t *link, bool driving) {
  if (link->driving == driving) {
    return;
  }
  link->driving = driving;
  if (!driving) {
    bus_release(link->bus, link->node, link->avr->cycle);
  }
}

void uart_link_reset(uart_link_t *link) {
  /* avr_reset() cleared every cycle timer and the USART registers. */
  if (link->driving) {
    bus_release(link->bus, link->node, link->avr->cycle);
  }
  link->driving = false;
  link->shift_busy = false;
  link->buffer_full = false;
  link->ubrr = 0;
  link->cycles_per_bit = 16.0; /* UBRR0 = 0, U2X0 = 0 after reset */
  link->uart->cycles_per_byte = (avr_cycle_count_t)(link->cycles_per_bit * BUS_FRAME_BITS_8N1);
  bus_baud_changed(link->bus);
  arm_rx(link);
}
