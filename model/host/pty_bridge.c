/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE /* pthread_setname_np */
#include "pty_bridge.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include "pacing.h"
#include "pty_baud.h"

static double pty_cycles_per_bit(void *ctx) { return ((const pty_bridge_t *)ctx)->cycles_per_bit; }

static void pty_deliver(void *ctx, const bus_rx_t *rx) {
  pty_bridge_t *pty = ctx;
  if (pty->hidden) {
    return;
  }
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

/* The client set bps (0: unknown, keep the last): the bus sees the adapter's rate for it. */
static void use_client_bps(pty_bridge_t *pty, double bps) {
  if (bps > 0.0 && bps != pty->bps) {
    pty->bps = bps;
    pty->actual_bps = usb_adapter_actual_bps(pty->adapter.config.kind, bps);
    pty->cycles_per_bit = sim_bps_to_cycles_per_bit(pty->actual_bps);
    bus_baud_changed(pty->bus);
  }
}

static void refresh_baud(pty_bridge_t *pty) { use_client_bps(pty, pty_get_bps(pty->master_fd)); }

static void set_nonblock(int fd) {
  const int flags = fcntl(fd, F_GETFL);
  (void)fcntl(fd, F_SETFL, flags | O_NONBLOCK);
  (void)fcntl(fd, F_SETFD, FD_CLOEXEC);
}

/* The calling thread's run-queue delay so far (time runnable but waiting for a CPU), in
 * microseconds, from its /proc/thread-self/schedstat opened as fd; 0 when unknown. */
static double run_delay_us(int fd) {
  char text[96];
  const ssize_t n = fd >= 0 ? pread(fd, text, sizeof(text) - 1u, 0) : -1;
  if (n <= 0) {
    return 0.0;
  }
  text[n] = '\0';
  unsigned long long run_ns = 0, wait_ns = 0;
  return sscanf(text, "%llu %llu", &run_ns, &wait_ns) == 2 ? (double)wait_ns / 1e3 : 0.0;
}

/* The reader thread: drains the master as soon as the client writes, so nothing the client
 * wrote is still in the pty when it flushes its output (tcflush) before the next packet.
 * Each chunk carries how long the reader waited for a CPU after its bytes woke it. */
static void *reader_main(void *arg) {
  pty_bridge_t *pty = arg;
  uint8_t buf[4096];
  const int schedstat_fd = open("/proc/thread-self/schedstat", O_RDONLY | O_CLOEXEC);
  for (;;) {
    uint32_t room;
    pthread_mutex_lock(&pty->lock);
    while (!pty->stopping &&
           (pty->inbox_used == PTY_BRIDGE_INBOX_BYTES || pty->chunk_count == PTY_BRIDGE_INBOX_CHUNKS)) {
      pthread_cond_wait(&pty->space, &pty->lock); /* the simulation is far behind the client */
    }
    const bool stopping = pty->stopping;
    room = PTY_BRIDGE_INBOX_BYTES - pty->inbox_used;
    pthread_mutex_unlock(&pty->lock);
    if (stopping) {
      break;
    }
    struct pollfd fds[2] = {{.fd = pty->master_fd, .events = POLLIN}, {.fd = pty->stop_pipe[0], .events = POLLIN}};
    const double waited_before_us = run_delay_us(schedstat_fd);
    const int r = poll(fds, 2, -1);
    if (r < 0) {
      if (errno == EINTR) {
        continue;
      }
      break;
    }
    if (fds[1].revents) {
      break;
    }
    if (!fds[0].revents) {
      continue;
    }
    const ssize_t n = read(pty->master_fd, buf, room < sizeof(buf) ? room : sizeof(buf));
    if (n <= 0) {
      if (n < 0 && (errno == EAGAIN || errno == EINTR)) {
        continue;
      }
      /* EIO / hang-up cannot last (the bridge keeps a slave open); do not spin meanwhile. */
      poll(&fds[1], 1, 1);
      continue;
    }
    const double wall = pacing_wall_us();
    const double reader_wait_us = run_delay_us(schedstat_fd) - waited_before_us;
    const double bps = pty_get_bps(pty->master_fd); /* the speed the client set before writing */
    pthread_mutex_lock(&pty->lock);
    const uint32_t offset = (pty->inbox_head + pty->inbox_used) % PTY_BRIDGE_INBOX_BYTES;
    for (ssize_t i = 0; i < n; i++) {
      pty->inbox[(offset + (uint32_t)i) % PTY_BRIDGE_INBOX_BYTES] = buf[i];
    }
    pty->inbox_used += (uint32_t)n;
    pty->chunks[(pty->chunk_head + pty->chunk_count) % PTY_BRIDGE_INBOX_CHUNKS] =
        (pty_in_chunk_t){.wall_us = wall, .reader_wait_us = reader_wait_us, .bps = bps, .offset = offset, .len = (uint32_t)n};
    pty->chunk_count++;
    pthread_mutex_unlock(&pty->lock);
    const char wake = 1;
    (void)!write(pty->wake_pipe[1], &wake, 1); /* a full pipe is awake already */
  }
  if (schedstat_fd >= 0) {
    close(schedstat_fd);
  }
  return NULL;
}

static int start_reader(pty_bridge_t *pty, char *err, size_t err_len) {
  pty->inbox = malloc(PTY_BRIDGE_INBOX_BYTES);
  if (!pty->inbox) {
    snprintf(err, err_len, "out of memory");
    return -1;
  }
  if (pipe(pty->stop_pipe) != 0 || pipe(pty->wake_pipe) != 0) {
    snprintf(err, err_len, "pipe: %s", strerror(errno));
    return -1;
  }
  set_nonblock(pty->stop_pipe[0]);
  set_nonblock(pty->stop_pipe[1]);
  set_nonblock(pty->wake_pipe[0]);
  set_nonblock(pty->wake_pipe[1]);
  /* Signals (SIGINT, SIGTERM...) go to the simulation thread, never to the reader. */
  sigset_t all, old;
  sigfillset(&all);
  pthread_sigmask(SIG_SETMASK, &all, &old);
  const int rc = pthread_create(&pty->reader, NULL, reader_main, pty);
  pthread_sigmask(SIG_SETMASK, &old, NULL);
  if (rc != 0) {
    snprintf(err, err_len, "cannot start the pty reader: %s", strerror(rc));
    return -1;
  }
  pty->reader_started = true;
  (void)pthread_setname_np(pty->reader, "ax12-pty-reader");
  return 0;
}

int pty_bridge_open(pty_bridge_t *pty, bus_t *bus, const sim_cycles_t *now, double initial_bps,
                    const usb_adapter_config_t *adapter, const char *link_path, char *err, size_t err_len) {
  memset(pty, 0, sizeof(*pty));
  pty->master_fd = pty->slave_fd = -1;
  pty->stop_pipe[0] = pty->stop_pipe[1] = pty->wake_pipe[0] = pty->wake_pipe[1] = -1;
  pthread_mutex_init(&pty->lock, NULL);
  pthread_cond_init(&pty->space, NULL);
  pty->bus = bus;
  pty->now = now;
  usb_adapter_init(&pty->adapter, adapter, *now);
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
  pty->actual_bps = usb_adapter_actual_bps(adapter->kind, initial_bps);
  pty->cycles_per_bit = sim_bps_to_cycles_per_bit(pty->actual_bps);
  refresh_baud(pty);
  const bus_node_ops_t ops = {.cycles_per_bit = pty_cycles_per_bit, .deliver = pty_deliver, .ctx = pty};
  pty->node = bus_add_node(bus, "pty", &ops);
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
  if (start_reader(pty, err, err_len) != 0) {
    pty_bridge_close(pty);
    return -1;
  }
  return 0;
}

void pty_bridge_close(pty_bridge_t *pty) {
  if (pty->reader_started) {
    pthread_mutex_lock(&pty->lock);
    pty->stopping = true;
    pthread_cond_signal(&pty->space);
    pthread_mutex_unlock(&pty->lock);
    const char stop = 1;
    (void)!write(pty->stop_pipe[1], &stop, 1);
    pthread_join(pty->reader, NULL);
    pty->reader_started = false;
  }
  for (int i = 0; i < 2; i++) {
    if (pty->stop_pipe[i] >= 0) {
      close(pty->stop_pipe[i]);
    }
    if (pty->wake_pipe[i] >= 0) {
      close(pty->wake_pipe[i]);
    }
    pty->stop_pipe[i] = pty->wake_pipe[i] = -1;
  }
  free(pty->inbox);
  pty->inbox = NULL;
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
  pty->out_count = pty->out_cap = pty->out_fed = 0;
}

/* Writes the n bytes at the head of out[] (already through the adapter) to the pty in one
 * write; what the pty cannot take is dropped and counted (the client does not read). */
static void send_to_client(pty_bridge_t *pty, size_t n) {
  uint8_t chunk[1024];
  while (n) {
    size_t len = 0;
    while (len < n && len < sizeof(chunk)) {
      chunk[len++] = pty->out[pty->out_head].value;
      pty->out_head = (pty->out_head + 1u) % pty->out_cap;
    }
    pty->out_count -= len;
    pty->out_fed -= len;
    n -= len;
    size_t done = 0;
    while (done < len) {
      const ssize_t w = write(pty->master_fd, chunk + done, len - done);
      if (w < 0 && errno == EINTR) {
        continue;
      }
      if (w <= 0) {
        pty->dropped_to_client += len - done;
        break;
      }
      done += (size_t)w;
    }
    pty->to_client += done;
  }
}

static bool byte_due(const pty_bridge_t *pty, sim_cycles_t now) {
  return pty->out_fed < pty->out_count && pty->out[(pty->out_head + pty->out_fed) % pty->out_cap].end <= now;
}

/* Feeds the adapter every byte whose stop bit has ended by the world's time, lets its timer
 * run to that time, and writes what it hands to the host: one write per USB packet, or with
 * the wire adapter every due byte in one write. */
static bool write_due(pty_bridge_t *pty, const pacing_t *pacing) {
  const sim_cycles_t now = *pty->now;
  const double wall = pacing ? pacing_wall_us() : 0.0;
  usb_adapter_t *a = &pty->adapter;
  const bool per_packet = a->config.kind != USB_ADAPTER_WIRE;
  size_t released = 0; /* wire: bytes handed to the host, written together at the end */
  bool moved = false;
  usb_adapter_packet_t packet;
  for (bool more = true; more;) {
    more = byte_due(pty, now);
    if (more) {
      usb_adapter_rx_byte(a, pty->out[(pty->out_head + pty->out_fed) % pty->out_cap].end);
      pty->out_fed++;
    } else {
      usb_adapter_advance(a, now);
    }
    while (usb_adapter_pop(a, &packet)) { /* after every byte: the ring stays short */
      moved = true;
      if (pacing) {
        delay_histogram_add(&pty->to_client_late, wall - pacing_wall_at(pacing, packet.at));
      }
      if (per_packet) {
        send_to_client(pty, packet.bytes);
      } else {
        released += packet.bytes;
      }
    }
  }
  if (released) {
    send_to_client(pty, released);
  }
  return moved;
}

/* Chunk c's first bit goes on the wire now, at wall time `wall` (pty_bridge.h, to_bus_delay). */
static void record_to_bus_delay(pty_bridge_t *pty, const pty_in_chunk_t *c, const pacing_t *pacing, double wall) {
  const double frame_wait_us = sim_cycles_to_us(c->at - c->entry);
  double entered_us = wall - frame_wait_us;
  if (pacing) {
    const double stands_for_us = pacing_wall_at(pacing, c->entry);
    if (stands_for_us > entered_us) {
      entered_us = stands_for_us;
    }
  }
  delay_histogram_add(&pty->to_bus_delay, entered_us - c->wall_us + c->reader_wait_us);
  if (c->reader_wait_us > pty->reader_wait_max_us) {
    pty->reader_wait_max_us = c->reader_wait_us;
  }
}

/* Stamps newly queued chunks with their simulated arrival, then puts the due ones on the
 * wire. Called with the lock held. */
static bool take_client(pty_bridge_t *pty, const pacing_t *pacing, double wall) {
  const sim_cycles_t now = *pty->now;
  sim_cycles_t previous = now;
  if (pty->chunk_stamped) {
    previous = pty->chunks[(pty->chunk_head + pty->chunk_stamped - 1u) % PTY_BRIDGE_INBOX_CHUNKS].at;
  }
  for (uint32_t i = pty->chunk_stamped; i < pty->chunk_count; i++) {
    pty_in_chunk_t *c = &pty->chunks[(pty->chunk_head + i) % PTY_BRIDGE_INBOX_CHUNKS];
    sim_cycles_t at = now;
    if (pty->anchored) {
      const double since = c->wall_us - pty->anchor_wall_us;
      sim_cycles_t target = pty->anchor_sim + (since > 0.0 ? (sim_cycles_t)(since * SIM_CYCLES_PER_US) : 0u);
      if (pacing) {
        const sim_cycles_t paced = pacing_sim_at(pacing, c->wall_us);
        if (paced < target) {
          target = paced;
        }
      }
      if (target > at) {
        at = target;
      }
    }
    if (at < previous) {
      at = previous; /* keep the client's order */
    }
    c->entry = at;
    c->at = previous = usb_adapter_tx_write(&pty->adapter, at, c->len);
  }
  pty->chunk_stamped = pty->chunk_count;

  bool moved = false;
  const uint32_t limit = usb_adapter_tx_queue_limit(&pty->adapter);
  const double max_queued = limit ? (double)limit : (double)PTY_BRIDGE_MAX_QUEUED;
  while (!pty->held && pty->chunk_count && pty->chunks[pty->chunk_head].at <= now) {
    if (pty->last_from_client_end > now) {
      const double queued = (double)(pty->last_from_client_end - now) / (pty->cycles_per_bit * 10.0);
      if (queued > max_queued) {
        break; /* the wire is far behind the client: wait, the inbox keeps the rest */
      }
    }
    const pty_in_chunk_t *c = &pty->chunks[pty->chunk_head];
    record_to_bus_delay(pty, c, pacing, wall);
    use_client_bps(pty, c->bps);
    for (uint32_t i = 0; i < c->len; i++) {
      pty->last_from_client_end =
          bus_send(pty->bus, pty->node, pty->inbox[(c->offset + i) % PTY_BRIDGE_INBOX_BYTES], now);
    }
    pty->from_client += c->len;
    pty->inbox_head = (pty->inbox_head + c->len) % PTY_BRIDGE_INBOX_BYTES;
    pty->inbox_used -= c->len;
    pty->chunk_head = (pty->chunk_head + 1u) % PTY_BRIDGE_INBOX_CHUNKS;
    pty->chunk_count--;
    pty->chunk_stamped--;
    moved = true;
  }
  if (moved) {
    pthread_cond_signal(&pty->space);
  }
  return moved;
}

bool pty_bridge_pump(pty_bridge_t *pty, const pacing_t *pacing) {
  char drain[64];
  while (read(pty->wake_pipe[0], drain, sizeof(drain)) > 0) {
  }
  refresh_baud(pty);
  bool moved = write_due(pty, pacing);
  const double wall = pacing_wall_us();
  pthread_mutex_lock(&pty->lock);
  moved |= take_client(pty, pacing, wall);
  pthread_mutex_unlock(&pty->lock);
  pty->anchor_wall_us = wall;
  pty->anchor_sim = *pty->now;
  pty->anchored = true;
  return moved;
}

sim_cycles_t pty_bridge_next_input(const pty_bridge_t *pty) {
  pthread_mutex_t *lock = (pthread_mutex_t *)&pty->lock;
  pthread_mutex_lock(lock);
  const sim_cycles_t at = pty->chunk_stamped && !pty->held ? pty->chunks[pty->chunk_head].at : SIM_CYCLES_NEVER;
  pthread_mutex_unlock(lock);
  return at;
}

sim_cycles_t pty_bridge_next_output(const pty_bridge_t *pty) { return usb_adapter_next_release(&pty->adapter); }

void pty_bridge_hold(pty_bridge_t *pty, bool held) { pty->held = held; }

void pty_bridge_hide(pty_bridge_t *pty, bool hidden) { pty->hidden = hidden; }

int pty_bridge_wake_fd(const pty_bridge_t *pty) { return pty->wake_pipe[0]; }

pthread_t pty_bridge_reader(const pty_bridge_t *pty) { return pty->reader; }
