/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Taking over simavr I/O register handlers (servo.c: EECR; uart_link.c: the USART;
 * quiet_timer.c: Timer0). A write hook replaces the register's handler and keeps the one it
 * replaced, so the new handler can chain to it; a read or write takeover replaces it for
 * good. */
#ifndef SIM_IO_HOOK_H
#define SIM_IO_HOOK_H

#include <stdbool.h>
#include <stdint.h>

struct avr_t;

typedef uint8_t (*io_read_fn)(struct avr_t *avr, uint16_t addr, void *param);
typedef void (*io_write_fn)(struct avr_t *avr, uint16_t addr, uint8_t v, void *param);

/* The handler a write hook replaced (c NULL: there was none; simavr stored the byte). */
typedef struct {
  io_write_fn c;
  void *param;
} io_write_hook_t;

/* Installs fn(param) as the write handler of addr; *replaced receives the previous one. */
void io_hook_write(struct avr_t *avr, uint16_t addr, io_write_fn fn, void *param, io_write_hook_t *replaced);

/* What the replaced handler would have done with the write: call it, or store the byte. */
void io_hook_chain(const io_write_hook_t *replaced, struct avr_t *avr, uint16_t addr, uint8_t v);

/* Installs fn(param) as the read / write handler of addr, replacing simavr's for good. */
void io_take_read(struct avr_t *avr, uint16_t addr, io_read_fn fn, void *param);
void io_take_write(struct avr_t *avr, uint16_t addr, io_write_fn fn, void *param);

/* True when simavr has a read handler for addr. */
bool io_has_read(const struct avr_t *avr, uint16_t addr);

#endif
