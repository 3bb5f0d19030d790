/* SPDX-License-Identifier: GPL-3.0-or-later */
/* `--log-bus FILE.csv`: every record of the bus monitor (model/bus/bus_monitor.h) as one CSV
 * row (bus_packet_csv, model/bus/bus_packet_text.h), after a header row (BUS_PACKET_CSV_HEADER).
 *
 * Rows go through stdio's buffer, flushed to the kernel by bus_log_tick when rows wait and
 * BUS_LOG_FLUSH_US of wall time have passed since the last flush (the first rows at once), so a
 * SIGKILL loses at most the rows of that last fraction of a second (the kernel keeps what was
 * written; no fsync, as with the state files). bus_log_close flushes the rest. A write that
 * fails is reported once on stderr; later rows are dropped and bus_log_close returns -1. */
#ifndef SIM_BUS_LOG_H
#define SIM_BUS_LOG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "bus_monitor.h"
#include "bus_packet_text.h"

#define BUS_LOG_FLUSH_US 100000.0

typedef struct {
  FILE *file;
  char path[4096];
  bool waiting;         /* rows written since the last flush */
  double last_flush_us; /* wall clock (caller's) of the last flush */
  bool failed;
  uint64_t rows;
} bus_log_t;

/* Creates (truncates) path and writes the header row. -1 with err set when it cannot. */
int bus_log_open(bus_log_t *log, const char *path, char *err, size_t err_len);

/* The listener (bus_packet_fn; ctx is the bus_log_t): one row. */
void bus_log_packet(void *ctx, const bus_packet_t *packet);

/* Flushes the rows written so far when BUS_LOG_FLUSH_US have passed since the last flush at
 * wall_us (any monotonic clock in microseconds). Cheap when there is nothing to do. */
void bus_log_tick(bus_log_t *log, double wall_us);

/* Flushes and closes. 0, or -1 with err set when a write failed at any time. */
int bus_log_close(bus_log_t *log, char *err, size_t err_len);

#endif
