/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "bus_log.h"

#include <errno.h>
#include <math.h>
#include <string.h>

static void fail(bus_log_t *log, int why) {
  if (!log->failed) {
    fprintf(stderr, "ax12-emu: bus log %s: %s; no more rows are written\n", log->path, strerror(why));
  }
  log->failed = true;
}

int bus_log_open(bus_log_t *log, const char *path, char *err, size_t err_len) {
  memset(log, 0, sizeof(*log));
  snprintf(log->path, sizeof(log->path), "%s", path);
  log->last_flush_us = -HUGE_VAL; /* the first rows go out at the first tick */
  log->file = fopen(path, "w");
  if (!log->file) {
    snprintf(err, err_len, "--log-bus %s: %s", path, strerror(errno));
    return -1;
  }
  if (fputs(BUS_PACKET_CSV_HEADER, log->file) == EOF || fflush(log->file) != 0) {
    snprintf(err, err_len, "--log-bus %s: %s", path, strerror(errno));
    fclose(log->file);
    log->file = NULL;
    return -1;
  }
  return 0;
}

void bus_log_packet(void *ctx, const bus_packet_t *packet) {
  bus_log_t *log = ctx;
  if (log->failed) {
    return;
  }
  char line[BUS_PACKET_CSV_MAX];
  const size_t n = bus_packet_csv(packet, line, sizeof(line));
  if (fwrite(line, 1, n, log->file) != n) {
    fail(log, errno);
    return;
  }
  log->rows++;
  log->waiting = true;
}

void bus_log_tick(bus_log_t *log, double wall_us) {
  if (!log->waiting || wall_us - log->last_flush_us < BUS_LOG_FLUSH_US) {
    return;
  }
  if (!log->failed && fflush(log->file) != 0) {
    fail(log, errno);
  }
  log->waiting = false;
  log->last_flush_us = wall_us;
}

int bus_log_close(bus_log_t *log, char *err, size_t err_len) {
  if (!log->file) {
    return 0;
  }
  const int why = (fflush(log->file) != 0 || ferror(log->file)) ? errno : 0;
  if (fclose(log->file) != 0 && !log->failed && !why) {
    fail(log, errno);
  }
  log->file = NULL;
  if (why && !log->failed) {
    fail(log, why);
  }
  if (log->failed) {
    snprintf(err, err_len, "bus log %s: rows were lost (a write failed)", log->path);
    return -1;
  }
  return 0;
}
