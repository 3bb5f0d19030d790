/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "pty_bridge.h"

#include <errno.h>
#include <fcntl.h>
#include <pty.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include "pty_baud.h"

static double pty_cycles_per_bit(void *ctx) { return ((const pty_bridge_t *)ctx)->cycles_per_bit; }

static void pty_deliver(void *ctx, const bus_rx_t *rx) {
  pty_bridge_t *pty = ctx;
  if (pty->out_count == pty->out_cap) {
    const size_t cap = pty->out_cap ? pty->out_cap * 2u : 1024u;
    pty_out_byte_t *grown = malloc(cap * sizeof(*grown));
    if (!grown) {
      abort();
    }
    for (size_t i = 0; i < pty->out_count; i++) {
      grown[i] = pty->out[(pty->out_head + i) % pty->out_cap];
    }
    free(pty->out);
    pty->out = grown;
    pty->out_cap = cap;
    pty->out_head = 0;
  }
  pty->out[(pty->out_head + pty->out_count) % pty->out_cap] = (pty_out_byte_t){.end = rx->end, .value = rx->value};
  pty->out_count++;
}

static void refresh_baud(pty_bridge_t *pty) {
  const double bps = pty_get_bps(pty->master_fd);
  if (bps > 0.0 && bps != pty->bps) {
    pty->bps = bps;
    pty->cycles_per_bit = sim_bps_to_cycles_per_bit(bps);
    bus_baud_changed(&pty->world->bus);
  }
}

int pty_bridge_open(pty_bridge_t *pty, world_t *world, double initial_bps, const char *link_path, char *err,
                    size_t err_len) {
  memset(pty, 0, sizeof(*pty));
  pty->master_fd = pty->slave_fd = -1;
  pty->world = world;
  struct termios raw;
  memset(&raw, 0, sizeof(raw));
  cfmakeraw(&raw);
  raw.c_cflag |= CLOCAL | CREAD;
  if (openpty(&pty->master_fd, &pty->slave_fd, pty->device, &raw, NULL) != 0) {
    snprintf(err, err_len, "cannot open a pseudo-terminal: %s", strerror(errno));
    return -1;
  }
  (void)fcntl(pty->master_fd, F_SETFD, FD_CLOEXEC);
  (void)fcntl(pty->slave_fd, F_SETFD, FD_CLOEXEC);
  const int flags = fcntl(pty->master_fd, F_GETFL);
  (void)fcntl(pty->master_fd, F_SETFL, flags | O_NONBLOCK);
  (void)pty_set_bps(pty->slave_fd, initial_bps);
  pty->bps = initial_bps;
  pty->cycles_per_bit = sim_bps_to_cycles_per_bit(initial_bps);
  refresh_baud(pty);
  const bus_node_ops_t ops = {.cycles_per_bit = pty_cycles_per_bit, .deliver = pty_deliver, .ctx = pty};
  pty->node = bus_add_node(&world->bus, "pty", &ops);
  if (pty->node < 0) {
    snprintf(err, err_len, "the bus is full");
    pty_bridge_close(pty);
    return -1;
  }
  if (link_path) {
    struct stat st;
    if (lstat(link_path, &st) == 0) {
      if (!S_ISLNK(st.st_mode)) {
        snprintf(err, err_len, "--link %s exists and is not a symlink", link_path);
        pty_bridge_close(pty);
        return -1;
      }
      (void)unlink(link_path);
    }
    if (symlink(pty->device, link_path) != 0) {
      snprintf(err, err_len, "cannot create --link %s: %s", link_path, strerror(errno));
      pty_bridge_close(pty);
      return -1;
    }
    snprintf(pty->link_path, sizeof(pty->link_path), "%s", link_path);
    pty->linked = true;
  }
  return 0;
}

void pty_bridge_close(pty_bridge_t *pty) {
  if (pty->linked) {
    /* Only our own link: someone may have replaced it meanwhile. */
    char target[sizeof(pty->device)];
    const ssize_t n = readlink(pty->link_path, target, sizeof(target) - 1u);
    if (n > 0) {
      target[n] = '\0';
      if (strcmp(target, pty->device) == 0) {
        (void)unlink(pty->link_path);
      }
    }
    pty->linked = false;
  }
  if (pty->master_fd >= 0) {
    close(pty->master_fd);
  }
  if (pty->slave_fd >= 0) {
    close(pty->slave_fd);
  }
  pty->master_fd = pty->slave_fd = -1;
  free(pty->out);
  pty->out = NULL;
  pty->out_count = pty->out_cap = 0;
}

static bool write_due(pty_bridge_t *pty) {
  const sim_cycles_t now = pty->world->now;
  uint8_t chunk[1024];
  size_t n = 0;
  while (pty->out_count && n < sizeof(chunk)) {
    const pty_out_byte_t *b = &pty->out[pty->out_head];
    if (b->end > now) {
      break;
    }
    chunk[n++] = b->value;
    pty->out_head = (pty->out_head + 1u) % pty->out_cap;
    pty->out_count--;
  }
  if (n == 0) {
    return false;
  }
  size_t done = 0;
  while (done < n) {
    const ssize_t w = write(pty->master_fd, chunk + done, n - done);
    if (w < 0 && errno == EINTR) {
      continue;
    }
    if (w <= 0) {
      pty->dropped_to_client += n - done;
      break;
    }
    done += (size_t)w;
  }
  pty->to_client += done;
  return true;
}

static bool read_client(pty_bridge_t *pty) {
  const sim_cycles_t now = pty->world->now;
  if (pty->last_from_client_end > now) {
    const double queued = (double)(pty->last_from_client_end - now) / (pty->cycles_per_bit * 10.0);
    if (queued > PTY_BRIDGE_MAX_QUEUED) {
      return false;
    }
  }
  uint8_t buf[1024];
  const ssize_t n = read(pty->master_fd, buf, sizeof(buf));
  if (n <= 0) {
    return false;
  }
  refresh_baud(pty); /* the speed the client set before writing */
  for (ssize_t i = 0; i < n; i++) {
    pty->last_from_client_end = bus_send(&pty->world->bus, pty->node, buf[i], now);
  }
  pty->from_client += (uint64_t)n;
  return true;
}

bool pty_bridge_pump(pty_bridge_t *pty) {
  refresh_baud(pty);
  bool moved = write_due(pty);
  moved |= read_client(pty);
  return moved;
}
