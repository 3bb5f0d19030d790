/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "simavr_patch_run.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

#include <avr_extint.h>
#include <avr_uart.h>
#include <sim_gdb.h>
#include <sim_io.h>

/* ---- I/O register handlers ---- */

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

/* ---- the cycle-timer list ---- */

unsigned simavr_cancel_timers_of(avr_t *avr, const void *owner) {
  unsigned cancelled = 0;
  for (;;) {
    avr_cycle_timer_slot_p slot = avr->cycle_timers.timer;
    while (slot && slot->param != owner) {
      slot = slot->next;
    }
    if (!slot) {
      return cancelled;
    }
    avr_cycle_timer_cancel(avr, slot->timer, slot->param);
    cancelled++;
  }
}

/* ---- the run loop ---- */

static void sleep_nothing(avr_t *avr, avr_cycle_count_t how_long) {
  (void)avr;
  (void)how_long;
}

void simavr_run_one_step(avr_t *avr) { simavr_step_core(avr, NULL, 0); }

void simavr_install_run_loop(avr_t *avr) {
  avr->sleep = sleep_nothing;
  avr->run = simavr_run_one_step;
}

bool simavr_reset_requested(const avr_t *avr) { return simavr_reset_requested_inline(avr); }

/* ---- the external-interrupt module ---- */

/* The context of simavr 1.6's level poll timer (avr_extint.c, private there; freed by the
 * poll itself when it ends). */
typedef struct {
  uint32_t eint_no;
  avr_extint_t *extint;
} extint_poll_context_t;

void simavr_extint_poll_off(avr_t *avr) {
  avr_extint_t *extint = NULL;
  for (avr_io_t *io = avr->io_port; io; io = io->next) {
    if (io->kind && strcmp(io->kind, "extint") == 0) {
      extint = (avr_extint_t *)io;
    }
  }
  if (!extint) {
    return;
  }
  for (uint8_t i = 0; i < 2; i++) {
    avr_extint_set_strict_lvl_trig(avr, i, 0);
  }
  bool cancelled;
  do {
    cancelled = false;
    for (avr_cycle_timer_slot_p t = avr->cycle_timers.timer; t; t = t->next) {
      const extint_poll_context_t *ctx = t->param;
      if (ctx && ctx->extint == extint && ctx->eint_no < EXTINT_COUNT) {
        void *param = t->param;
        avr_cycle_timer_cancel(avr, t->timer, param);
        free(param);
        cancelled = true;
        break;
      }
    }
  } while (cancelled);
}

/* ---- the USART ---- */

void simavr_uart_rx_limiter_reset(struct avr_uart_t *uart) {
  uart->rx_cnt = 0;
  uart->rxc_raise_time = 0;
}

/* ---- the pending-interrupt list ---- */

/* simavr 1.6's accessors of the list, as sim_interrupts.c defines them (static there). */
DEFINE_FIFO(avr_int_vector_p, avr_int_pending);

void simavr_interrupts_make_room(struct avr_t *avr) {
  avr_int_pending_t *const list = &avr->interrupts.pending;
  if (!avr_int_pending_isfull(list)) {
    return;
  }
  avr_int_vector_p kept[avr_int_pending_fifo_size];
  unsigned count = 0;
  while (!avr_int_pending_isempty(list)) {
    avr_int_vector_p vector = avr_int_pending_read(list);
    bool listed = false;
    for (unsigned i = 0; i < count; i++) {
      listed |= kept[i] == vector;
    }
    if (vector->pending && !listed) {
      kept[count++] = vector;
    }
  }
  for (unsigned i = 0; i < count; i++) {
    avr_int_pending_write(list, kept[i]);
  }
}

/* ---- the gdb stub ---- */

/* simavr 1.6's avr_gdb_t and its breakpoint lists (sim_gdb.c, private there). */
#define GDB_WATCH_LIMIT 32
typedef struct {
  uint32_t len;
  struct {
    uint32_t addr, size, kind;
  } points[GDB_WATCH_LIMIT];
} gdb_watchpoints_t;

typedef struct {
  avr_t *avr;
  int listen; /* listening socket */
  int s;      /* the connection, -1 when none */
  gdb_watchpoints_t breakpoints;
  gdb_watchpoints_t watchpoints;
} gdb_stub_t;

static gdb_stub_t *stub_of(const avr_t *avr) { return (gdb_stub_t *)avr->gdb; }

/* Runs fn(avr, arg) with stdout on file descriptor `to` (the stub prints on stdout). */
static int with_stdout_on(int to, int (*fn)(avr_t *avr, int arg), avr_t *avr, int arg) {
  fflush(stdout);
  const int saved = dup(STDOUT_FILENO);
  if (saved >= 0 && to >= 0) {
    (void)dup2(to, STDOUT_FILENO);
  }
  const int r = fn(avr, arg);
  fflush(stdout);
  if (saved >= 0) {
    (void)dup2(saved, STDOUT_FILENO);
    close(saved);
  }
  return r;
}

static int gdb_init(avr_t *avr, int unused) {
  (void)unused;
  return avr_gdb_init(avr);
}

static int gdb_process(avr_t *avr, int unused) {
  (void)unused;
  return avr_gdb_processor(avr, 0);
}

static int loopback_listener(unsigned port, char *err, size_t err_len) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    snprintf(err, err_len, "gdb: socket: %s", strerror(errno));
    return -1;
  }
  const int on = 1;
  (void)setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &on, sizeof(on));
  struct sockaddr_in address = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (bind(fd, (struct sockaddr *)&address, sizeof(address)) != 0 || listen(fd, 1) != 0) {
    snprintf(err, err_len, "gdb: cannot listen on 127.0.0.1:%u: %s", port, strerror(errno));
    close(fd);
    return -1;
  }
  return fd;
}

bool simavr_gdb_open(avr_t *avr, unsigned port, char *err, size_t err_len) {
  const int listener = loopback_listener(port, err, err_len);
  if (listener < 0) {
    return false;
  }
  avr->gdb_port = 0; /* the stub's own socket: any free port, replaced below */
  /* Its line names the port it is about to lose: to /dev/null. */
  const int null_fd = open("/dev/null", O_WRONLY | O_CLOEXEC);
  const int started = with_stdout_on(null_fd, gdb_init, avr, 0);
  if (null_fd >= 0) {
    close(null_fd);
  }
  if (started != 0 || !avr->gdb) {
    snprintf(err, err_len, "gdb: simavr's stub did not start");
    close(listener);
    return false;
  }
  gdb_stub_t *g = stub_of(avr);
  if (g->avr != avr || g->listen < 0 || g->s != -1 || g->breakpoints.len != 0) {
    snprintf(err, err_len, "gdb: simavr's stub is not laid out as in simavr 1.6");
    avr_deinit_gdb(avr);
    simavr_install_run_loop(avr);
    close(listener);
    return false;
  }
  close(g->listen);
  g->listen = listener;
  avr->gdb_port = (int)port;
  simavr_install_run_loop(avr);
  return true;
}

void simavr_gdb_close(avr_t *avr) {
  if (avr->gdb) {
    const int state = avr->state;
    avr_deinit_gdb(avr);
    avr->state = state;
    simavr_install_run_loop(avr);
  }
}

/* simavr 1.6's stub answers gdb's detach packet ("D", or "D;pid") as an unknown one, so gdb's
 * `detach` fails ("Remote doesn't know how to detach"). When the next packet waiting on the
 * connection is a detach, it is served here: acknowledged, answered OK, and the connection
 * ended as the stub ends one gdb closes (breakpoints and watchpoints cleared, the core let
 * run). True when it was one. */
static bool served_detach(avr_t *avr, gdb_stub_t *g) {
  char peeked[64];
  const ssize_t n = recv(g->s, peeked, sizeof(peeked) - 1u, MSG_PEEK | MSG_DONTWAIT);
  if (n <= 0) {
    return false;
  }
  peeked[n] = '\0';
  const char *packet = peeked + strspn(peeked, "+-");
  const char *end = strchr(packet, '#');
  if (strncmp(packet, "$D", 2) != 0 || !(packet[2] == '#' || packet[2] == ';') || !end || end[1] == '\0' ||
      end[2] == '\0') {
    return false;
  }
  const size_t length = (size_t)(end + 3 - peeked);
  char taken[sizeof(peeked)];
  if (recv(g->s, taken, length, MSG_DONTWAIT) != (ssize_t)length) {
    return false;
  }
  static const char reply[] = "+$OK#9a";
  (void)send(g->s, reply, sizeof(reply) - 1u, MSG_NOSIGNAL);
  close(g->s);
  g->s = -1;
  g->breakpoints.len = 0;
  g->watchpoints.len = 0;
  avr->state = cpu_Running;
  return true;
}

bool simavr_gdb_serve(avr_t *avr, unsigned wait_us) {
  gdb_stub_t *g = stub_of(avr);
  if (!g) {
    return false;
  }
  bool due = avr->state == cpu_StepDone;
  if (!due) {
    fd_set read_set;
    FD_ZERO(&read_set);
    const int fd = g->s != -1 ? g->s : g->listen;
    FD_SET(fd, &read_set);
    struct timeval timeout = {.tv_sec = wait_us / 1000000u, .tv_usec = wait_us % 1000000u};
    due = select(fd + 1, &read_set, NULL, NULL, &timeout) > 0;
    if (due && g->s != -1 && served_detach(avr, g)) {
      return true;
    }
  }
  if (due) {
    (void)with_stdout_on(STDERR_FILENO, gdb_process, avr, 0);
  }
  return due;
}

void simavr_gdb_report_stop(avr_t *avr) {
  if (avr->gdb) {
    avr->state = cpu_StepDone; /* avr_gdb_processor reports it and stops the core */
    (void)with_stdout_on(STDERR_FILENO, gdb_process, avr, 0);
  }
}

bool simavr_gdb_breakpoint_at(const avr_t *avr, uint32_t pc) {
  const gdb_stub_t *g = stub_of(avr);
  if (!g) {
    return false;
  }
  for (uint32_t i = 0; i < g->breakpoints.len && i < GDB_WATCH_LIMIT; i++) {
    if (g->breakpoints.points[i].addr == pc) {
      return true;
    }
  }
  return false;
}

bool simavr_gdb_has_breakpoints(const avr_t *avr) {
  const gdb_stub_t *g = stub_of(avr);
  return g && g->breakpoints.len != 0;
}
