/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_bus_master.h"

#include <stdio.h>
#include <string.h>

#include "dxl_protocol.h"
#include "dxl_table.h"

int emu_bus_master_open(emu_bus_master_t *m, world_t *world, pty_bridge_t *pty, const servo_probe_map_t *map) {
  memset(m, 0, sizeof(*m));
  m->world = world;
  m->pty = pty;
  m->map = map;
  m->master = world_add_master(world, pty->actual_bps); /* the client's baud: no shorter bus lookahead */
  if (!m->master) {
    return -1;
  }
  /* Named for the bus monitor and --log-bus, whose instruction packets it sends. */
  snprintf(world->bus.nodes[m->master->node].name, sizeof(world->bus.nodes[m->master->node].name), "control");
  return 0;
}

void emu_bus_master_close(emu_bus_master_t *m) {
  pty_bridge_hide(m->pty, false);
  pty_bridge_hold(m->pty, false);
  m->sending = false;
}

bool emu_bus_master_queue(emu_bus_master_t *m, unsigned token, const uint8_t *bytes, size_t len) {
  if (m->queue_count == EMU_BUS_MASTER_QUEUE || len == 0 || len > EMU_BUS_MASTER_PACKET_MAX) {
    return false;
  }
  emu_bus_master_job_t *job = &m->queue[(m->queue_head + m->queue_count++) % EMU_BUS_MASTER_QUEUE];
  job->token = token;
  memcpy(job->bytes, bytes, len);
  job->len = len;
  return true;
}

bool emu_bus_master_busy(const emu_bus_master_t *m) { return m->sending || m->queue_count > 0; }

void emu_bus_master_forget(emu_bus_master_t *m) {
  if (!m->sending) {
    master_rx_clear(m->master);
  }
}

static sim_cycles_t bus_last_activity(const bus_t *bus) {
  sim_cycles_t last = 0;
  for (size_t i = 0; i < bus->node_count; i++) {
    if (bus->nodes[i].tx_end > last) {
      last = bus->nodes[i].tx_end;
    }
  }
  return last;
}

/* The master speaks at the baud of the servo addressed (the first servo for broadcast). */
static void choose_baud(emu_bus_master_t *m, uint8_t id) {
  size_t chosen = 0;
  servo_probe_t p;
  for (size_t i = 0; i < m->world->servo_count; i++) {
    servo_probe_read(m->world->servos[i], m->map, &p);
    if (p.have_table && p.table[CT_ADDR_ID] == id) {
      chosen = i;
      break;
    }
  }
  servo_probe_read(m->world->servos[chosen], m->map, &p);
  master_set_baud_reg(m->master, p.have_table ? p.table[CT_ADDR_BAUD_RATE] : 1u);
}

static void start(emu_bus_master_t *m) {
  const emu_bus_master_job_t *job = &m->queue[m->queue_head];
  choose_baud(m, job->bytes[2]);
  pty_bridge_hide(m->pty, true);
  master_rx_clear(m->master);
  m->request_end = master_send(m->master, job->bytes, job->len);
  m->sending = true;
}

static sim_cycles_t byte_cycles(const emu_bus_master_t *m) {
  return (sim_cycles_t)(m->master->cycles_per_bit * 10.0);
}

/* True once the reply is complete or no more of it can come.
 *
 * Not master_exchange() (model/bus/master_request.c), for two reasons: that one runs the
 * simulation itself until the reply is in, while here the serve loop owns the world's steps
 * (real-time pacing, the pty) and only asks between them; and it waits for a number of bytes
 * the caller expects, while a packet from the control socket may be any instruction, so here
 * the reply's own LENGTH byte says when it is whole. */
static bool reply_over(const emu_bus_master_t *m) {
  const sim_cycles_t now = m->world->now;
  if (now < m->request_end) {
    return false;
  }
  uint8_t got[EMU_BUS_MASTER_PACKET_MAX];
  const size_t n = master_rx_values(m->master, got, sizeof got);
  const sim_cycles_t gap = EMU_BUS_MASTER_GAP_BYTES * byte_cycles(m);
  if (n == 0) {
    return now >= m->request_end + sim_us(EMU_BUS_MASTER_WAIT_US) + gap;
  }
  if (n >= 4u && got[0] == DXL_HEADER_BYTE && got[1] == DXL_HEADER_BYTE && n >= (size_t)got[3] + 4u) {
    return true;
  }
  return now >= master_rx(m->master, n - 1u)->end + gap;
}

void emu_bus_master_poll(emu_bus_master_t *m, emu_bus_master_done_fn done, void *ctx) {
  if (m->sending) {
    if (!reply_over(m)) {
      return;
    }
    uint8_t got[EMU_BUS_MASTER_PACKET_MAX];
    const size_t n = master_rx_values(m->master, got, sizeof got);
    pty_bridge_hide(m->pty, false);
    m->sending = false;
    const unsigned token = m->queue[m->queue_head].token;
    m->queue_head = (m->queue_head + 1u) % EMU_BUS_MASTER_QUEUE;
    m->queue_count--;
    done(ctx, token, got, n);
  }
  if (m->queue_count == 0) {
    pty_bridge_hold(m->pty, false);
    return;
  }
  /* The client waits from now on; the packet goes once nothing has moved on the bus for
   * EMU_BUS_MASTER_IDLE_US (a servo still answering the client, even late, has answered). */
  pty_bridge_hold(m->pty, true);
  if (m->world->bus.pending_total == 0 &&
      m->world->now >= bus_last_activity(&m->world->bus) + sim_us(EMU_BUS_MASTER_IDLE_US)) {
    start(m);
  }
}
