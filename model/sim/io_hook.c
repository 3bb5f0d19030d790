/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "io_hook.h"

#include <stdbool.h>
#include <stddef.h>

#include <sim_avr.h>
#include <sim_io.h>

#define IO_SLOT(avr, addr) ((avr)->io[AVR_DATA_TO_IO(addr)])

void io_hook_write(struct avr_t *avr, uint16_t addr, io_write_fn fn, void *param, io_write_hook_t *replaced) {
  replaced->c = (io_write_fn)IO_SLOT(avr, addr).w.c;
  replaced->param = IO_SLOT(avr, addr).w.param;
  io_take_write(avr, addr, fn, param);
}

void io_hook_chain(const io_write_hook_t *replaced, struct avr_t *avr, uint16_t addr, uint8_t v) {
  if (replaced->c) {
    replaced->c(avr, addr, v, replaced->param);
  } else {
    avr->data[addr] = v;
  }
}

void io_take_read(struct avr_t *avr, uint16_t addr, io_read_fn fn, void *param) {
  IO_SLOT(avr, addr).r.c = (avr_io_read_t)fn;
  IO_SLOT(avr, addr).r.param = param;
}

void io_take_write(struct avr_t *avr, uint16_t addr, io_write_fn fn, void *param) {
  IO_SLOT(avr, addr).w.c = (avr_io_write_t)fn;
  IO_SLOT(avr, addr).w.param = param;
}

bool io_has_read(const struct avr_t *avr, uint16_t addr) { return IO_SLOT(avr, addr).r.c != NULL; }
