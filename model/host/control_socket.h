/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The serve loop's control socket: a Unix-domain stream socket on which local programs (the
 * dashboard, `ax12 world`) send one request per line and read one reply or event per line.
 * It knows nothing of what the lines say (emu_control.c does); it only moves lines.
 *
 * Never blocks the simulation: control_socket_poll() accepts, reads and writes what the
 * kernel takes at once. A request line is at most CONTROL_LINE_MAX bytes (a longer one is
 * answered by on_line with line == NULL, then skipped to its newline). A client that does not
 * read its output falls behind by at most CONTROL_OUT_MAX bytes, then is disconnected: a
 * stalled page never stops the bus. */
#ifndef SIM_CONTROL_SOCKET_H
#define SIM_CONTROL_SOCKET_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define CONTROL_MAX_CLIENTS 16u
#define CONTROL_LINE_MAX 8192u
#define CONTROL_OUT_MAX (4u << 20)

typedef struct {
  int fd; /* -1: free */
  char in[CONTROL_LINE_MAX];
  size_t in_len;
  bool overlong; /* skipping the rest of a line longer than CONTROL_LINE_MAX */
  char *out;
  size_t out_len, out_cap;
  uint32_t user; /* the request handler's own state for this client (e.g. subscriptions) */
} control_client_t;

typedef struct control_socket {
  int listen_fd;
  char path[108];
  control_client_t clients[CONTROL_MAX_CLIENTS];
  /* A complete request line (without its newline, NUL-terminated and writable), or NULL for a
   * line that was too long. The handler answers with control_socket_send(). */
  void (*on_line)(void *ctx, struct control_socket *cs, unsigned client, char *line);
  void *ctx;
} control_socket_t;

/* Listens on path. A socket file left by an emulator that is gone is replaced; one that a
 * running program answers on is not (-1, err names the path). */
int control_socket_open(control_socket_t *cs, const char *path, char *err, size_t err_len);

/* Closes every connection and removes the socket file. */
void control_socket_close(control_socket_t *cs);

/* Accepts new clients, hands complete lines to on_line, writes pending output. */
void control_socket_poll(control_socket_t *cs);

/* Queues line + '\n' for a client (dropped when the client is gone). */
void control_socket_send(control_socket_t *cs, unsigned client, const char *line);

/* Whether client is connected. */
bool control_socket_connected(const control_socket_t *cs, unsigned client);

#endif
