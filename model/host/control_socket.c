/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include "control_socket.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

static void drop_client(control_client_t *c) {
  if (c->fd >= 0) {
    close(c->fd);
  }
  free(c->out);
  memset(c, 0, sizeof(*c));
  c->fd = -1;
}

/* True when a program answers on the socket at path. */
static bool someone_listens(const struct sockaddr_un *addr) {
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    return false;
  }
  const bool answered = connect(fd, (const struct sockaddr *)addr, sizeof(*addr)) == 0;
  close(fd);
  return answered;
}

int control_socket_open(control_socket_t *cs, const char *path, char *err, size_t err_len) {
  memset(cs, 0, sizeof(*cs));
  cs->listen_fd = -1;
  for (unsigned i = 0; i < CONTROL_MAX_CLIENTS; i++) {
    cs->clients[i].fd = -1;
  }
  struct sockaddr_un addr = {.sun_family = AF_UNIX};
  if (strlen(path) >= sizeof(addr.sun_path)) {
    snprintf(err, err_len, "control socket %s: the path is longer than %zu bytes", path, sizeof(addr.sun_path) - 1u);
    return -1;
  }
  snprintf(addr.sun_path, sizeof(addr.sun_path), "%s", path);
  struct stat st;
  if (lstat(path, &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) {
      snprintf(err, err_len, "control socket %s: a file that is not a socket is there", path);
      return -1;
    }
    if (someone_listens(&addr)) {
      snprintf(err, err_len, "control socket %s: another running emulator serves it", path);
      return -1;
    }
    unlink(path); /* left by an emulator that is gone */
  }
  cs->listen_fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (cs->listen_fd < 0 || bind(cs->listen_fd, (const struct sockaddr *)&addr, sizeof(addr)) != 0 ||
      listen(cs->listen_fd, 8) != 0) {
    snprintf(err, err_len, "control socket %s: %s", path, strerror(errno));
    if (cs->listen_fd >= 0) {
      close(cs->listen_fd);
      cs->listen_fd = -1;
    }
    return -1;
  }
  snprintf(cs->path, sizeof(cs->path), "%s", path);
  return 0;
}

void control_socket_close(control_socket_t *cs) {
  for (unsigned i = 0; i < CONTROL_MAX_CLIENTS; i++) {
    drop_client(&cs->clients[i]);
  }
  if (cs->listen_fd >= 0) {
    close(cs->listen_fd);
    unlink(cs->path);
    cs->listen_fd = -1;
  }
}

bool control_socket_connected(const control_socket_t *cs, unsigned client) {
  return client < CONTROL_MAX_CLIENTS && cs->clients[client].fd >= 0;
}

void control_socket_send(control_socket_t *cs, unsigned client, const char *line) {
  if (!control_socket_connected(cs, client)) {
    return;
  }
  control_client_t *c = &cs->clients[client];
  const size_t n = strlen(line);
  if (c->out_len + n + 1u > CONTROL_OUT_MAX) {
    drop_client(c); /* it has stopped reading */
    return;
  }
  if (c->out_len + n + 1u > c->out_cap) {
    size_t cap = c->out_cap ? c->out_cap : 4096u;
    while (cap < c->out_len + n + 1u) {
      cap *= 2u;
    }
    char *grown = realloc(c->out, cap);
    if (!grown) {
      drop_client(c);
      return;
    }
    c->out = grown;
    c->out_cap = cap;
  }
  memcpy(c->out + c->out_len, line, n);
  c->out[c->out_len + n] = '\n';
  c->out_len += n + 1u;
}

static void accept_clients(control_socket_t *cs) {
  for (;;) {
    const int fd = accept4(cs->listen_fd, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      return;
    }
    unsigned slot = 0;
    while (slot < CONTROL_MAX_CLIENTS && cs->clients[slot].fd >= 0) {
      slot++;
    }
    if (slot == CONTROL_MAX_CLIENTS) {
      static const char full[] = "{\"ok\":false,\"error\":\"too many control clients\"}\n";
      (void)!write(fd, full, sizeof(full) - 1u);
      close(fd);
      continue;
    }
    cs->clients[slot].fd = fd;
  }
}

/* Splits what arrived into lines and hands each to on_line. */
static void take_lines(control_socket_t *cs, unsigned index) {
  control_client_t *c = &cs->clients[index];
  size_t start = 0;
  for (size_t i = 0; i < c->in_len; i++) {
    if (c->in[i] != '\n') {
      continue;
    }
    c->in[i] = '\0';
    if (c->overlong) {
      c->overlong = false;
    } else {
      cs->on_line(cs->ctx, cs, index, c->in + start);
    }
    if (c->fd < 0) {
      return; /* the handler's reply overflowed it */
    }
    start = i + 1u;
  }
  memmove(c->in, c->in + start, c->in_len - start);
  c->in_len -= start;
  if (c->in_len == sizeof(c->in)) {
    if (!c->overlong) {
      cs->on_line(cs->ctx, cs, index, NULL);
    }
    c->overlong = true;
    c->in_len = 0;
  }
}

static void read_client(control_socket_t *cs, unsigned index) {
  control_client_t *c = &cs->clients[index];
  for (;;) {
    const ssize_t n = read(c->fd, c->in + c->in_len, sizeof(c->in) - c->in_len);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
      drop_client(c);
      return;
    }
    if (n < 0) {
      return;
    }
    c->in_len += (size_t)n;
    take_lines(cs, index);
    if (c->fd < 0) {
      return;
    }
  }
}

static void write_client(control_client_t *c) {
  while (c->out_len) {
    const ssize_t n = send(c->fd, c->out, c->out_len, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno != EAGAIN && errno != EINTR) {
        drop_client(c);
      }
      return;
    }
    memmove(c->out, c->out + n, c->out_len - (size_t)n);
    c->out_len -= (size_t)n;
  }
}

void control_socket_poll(control_socket_t *cs) {
  if (cs->listen_fd < 0) {
    return;
  }
  accept_clients(cs);
  for (unsigned i = 0; i < CONTROL_MAX_CLIENTS; i++) {
    if (cs->clients[i].fd >= 0) {
      read_client(cs, i);
    }
    if (cs->clients[i].fd >= 0) {
      write_client(&cs->clients[i]);
    }
  }
}
