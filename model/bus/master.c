/* SPDX-License-Identifier: MIT */
#include "master.h"

#include <stdlib.h>

static double master_cycles_per_bit(void *ctx) { return ((const master_t *)ctx)->cycles_per_bit; }

static void master_deliver(void *ctx, const bus_rx_t *rx) {
  master_t *m = ctx;
  if (m->rx_count == m->rx_cap) {
    const size_t cap = m->rx_cap ? m->rx_cap * 2u : 256u;
    bus_rx_t *grown = realloc(m->rx, cap * sizeof(*grown));
    if (!grown) {
      abort();
    }
    m->rx = grown;
    m->rx_cap = cap;
  }
  m->rx[m->rx_count++] = *rx;
}

master_t *master_create(bus_t *bus, const sim_cycles_t *now, double bps) {
  master_t *m = calloc(1, sizeof(*m));
  if (!m) {
    return NULL;
  }
  m->bus = bus;
  m->now = now;
  m->cycles_per_bit = sim_bps_to_cycles_per_bit(bps);
  const bus_node_ops_t ops = {.cycles_per_bit = master_cycles_per_bit, .deliver = master_deliver, .ctx = m};
  m->node = bus_add_node(bus, "master", &ops);
  if (m->node < 0) {
    free(m);
    return NULL;
  }
  return m;
}

void master_destroy(master_t *master) {
  if (master) {
    free(master->rx);
    free(master);
  }
}

void master_set_bps(master_t *master, double bps) {
  master->cycles_per_bit = sim_bps_to_cycles_per_bit(bps);
  bus_baud_changed(master->bus);
}

void master_set_baud_reg(master_t *master, unsigned value) { master_set_bps(master, sim_baud_reg_to_bps(value)); }

sim_cycles_t master_send(master_t *master, const uint8_t *bytes, size_t count) {
  sim_cycles_t end = master->tx_end > *master->now ? master->tx_end : *master->now;
  for (size_t i = 0; i < count; i++) {
    end = bus_send(master->bus, master->node, bytes[i], *master->now);
  }
  master->tx_end = end;
  return end;
}

size_t master_rx_count(const master_t *master) {
  size_t n = master->rx_count;
  while (n > 0 && master->rx[n - 1u].end > *master->now) {
    n--;
  }
  return n;
}

const bus_rx_t *master_rx(const master_t *master, size_t index) {
  return index < master_rx_count(master) ? &master->rx[index] : NULL;
}

size_t master_rx_values(const master_t *master, uint8_t *out, size_t max) {
  const size_t n = master_rx_count(master);
  size_t i = 0;
  for (; i < n && i < max; i++) {
    out[i] = master->rx[i].value;
  }
  return i;
}

void master_rx_clear(master_t *master) {
  const size_t visible = master_rx_count(master);
  for (size_t i = visible; i < master->rx_count; i++) {
    master->rx[i - visible] = master->rx[i];
  }
  master->rx_count -= visible;
}
