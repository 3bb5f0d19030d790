/* SPDX-License-Identifier: MIT */
/* A bus master for tests and tools: sends bytes at its baud, starting at the world's time
 * (back to back, 10 bit times each), and records every byte it receives with its wire
 * timestamps. A received byte becomes visible once the world's clock reaches its end.
 * Pure C, no simavr (MIT, as the rest of model/bus): the world's clock is read through a
 * pointer, so the master runs against any scheduler of the bus. */
#ifndef SIM_MASTER_H
#define SIM_MASTER_H

#include <stddef.h>
#include <stdint.h>

#include "bus.h"
#include "sim_time.h"

typedef struct {
  bus_t *bus;
  const sim_cycles_t *now; /* the world's clock (world_t.now), read-only */
  int node;
  double cycles_per_bit;
  sim_cycles_t tx_end; /* end of the last byte sent */
  bus_rx_t *rx;
  size_t rx_count, rx_cap;
} master_t;

/* Adds a master at bps bit/s to bus, whose scheduler's clock is *now. NULL if the bus is
 * full. */
master_t *master_create(bus_t *bus, const sim_cycles_t *now, double bps);
void master_destroy(master_t *master);

void master_set_bps(master_t *master, double bps);
/* Baud Rate register value: 2 000 000 / (value + 1) bit/s. */
void master_set_baud_reg(master_t *master, unsigned value);

/* Queues bytes on the wire from max(now, end of the previous byte); returns the end of the
 * last byte's stop bit. */
sim_cycles_t master_send(master_t *master, const uint8_t *bytes, size_t count);

/* Bytes received whose end is at or before the world's time. */
size_t master_rx_count(const master_t *master);
const bus_rx_t *master_rx(const master_t *master, size_t index);
/* The received values, up to max; returns how many. */
size_t master_rx_values(const master_t *master, uint8_t *out, size_t max);
void master_rx_clear(master_t *master);

#endif
