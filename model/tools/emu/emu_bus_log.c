/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_bus_log.h"

#include <stdio.h>
#include <string.h>

#include "pacing.h"

int emu_bus_log_start(emu_bus_log_t *bl, const char *path, bus_t *bus, int client_node, char *err, size_t err_len) {
  memset(bl, 0, sizeof(*bl));
  if (!path) {
    return 0;
  }
  if (bus_log_open(&bl->log, path, err, err_len) != 0) {
    return -1;
  }
  bl->monitor = bus_monitor_create(bus, sim_us(BUS_MONITOR_DEFAULT_GAP_US));
  if (!bl->monitor) {
    char ignored[64];
    (void)bus_log_close(&bl->log, ignored, sizeof(ignored));
    snprintf(err, err_len, "out of memory for the bus monitor");
    return -1;
  }
  bus_monitor_set_client(bl->monitor, client_node);
  (void)bus_monitor_add_listener(bl->monitor, bus_log_packet, &bl->log); /* the first: never full */
  return 0;
}

void emu_bus_log_tick(emu_bus_log_t *bl, sim_cycles_t now) {
  if (bl->monitor) {
    bus_monitor_flush(bl->monitor, now);
    bus_log_tick(&bl->log, pacing_wall_us());
  }
}

int emu_bus_log_stop(emu_bus_log_t *bl, bool stats) {
  if (!bl->monitor) {
    return 0;
  }
  bus_monitor_finish(bl->monitor);
  if (stats) {
    const bus_monitor_t *m = bl->monitor;
    fprintf(stderr,
            "ax12-emu: bus log %s: %llu rows: %llu instructions, %llu status packets, %llu garbage, %llu protocol "
            "2.0\n",
            bl->log.path, (unsigned long long)bl->log.rows,
            (unsigned long long)bus_monitor_count(m, BUS_PACKET_INSTRUCTION),
            (unsigned long long)bus_monitor_count(m, BUS_PACKET_STATUS),
            (unsigned long long)bus_monitor_count(m, BUS_PACKET_GARBAGE),
            (unsigned long long)bus_monitor_count(m, BUS_PACKET_PROTOCOL2));
  }
  bus_monitor_destroy(bl->monitor);
  bl->monitor = NULL;
  char err[sizeof(bl->log.path) + 64];
  if (bus_log_close(&bl->log, err, sizeof(err)) != 0) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    return -1;
  }
  return 0;
}
