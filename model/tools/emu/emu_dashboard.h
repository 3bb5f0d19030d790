/* SPDX-License-Identifier: GPL-3.0-or-later */
/* `ax12-emu serve --dashboard [HOST:]PORT`: the live dashboard runs as a child process
 * (scripts/ax12_dashboard.py in the project's Python environment), a client of the control
 * socket like any other, so a slow or failed page never stops the bus. */
#ifndef EMU_DASHBOARD_H
#define EMU_DASHBOARD_H

#include <stddef.h>
#include <sys/types.h>

typedef struct {
  pid_t pid;    /* 0: not running */
  int out_fd;   /* its stdout, kept open (it prints one line) */
  char url[256];
} emu_dashboard_t;

/* Starts the dashboard on listen ("PORT" or "HOST:PORT") against the control socket at
 * control_path, and waits (up to a few seconds) until it serves: 0 with d->url set, or -1
 * with err set (it is stopped again). The Python interpreter is $AX12_PYTHON, else the
 * project's .venv. */
int emu_dashboard_start(emu_dashboard_t *d, const char *control_path, const char *listen, char *err, size_t err_len);

/* Stops it (SIGTERM, then waits). */
void emu_dashboard_stop(emu_dashboard_t *d);

#endif
