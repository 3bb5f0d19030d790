/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include "emu_dashboard.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#ifndef AX12_REPO_DIR
#define AX12_REPO_DIR "."
#endif
#ifndef AX12_BUILD_DIR
#define AX12_BUILD_DIR "build"
#endif

/* aiohttp's import and start take about a second; a loaded machine may take several. */
#define START_TIMEOUT_MS 30000

static long long now_ms(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (long long)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

/* Reads the child's first line, up to the timeout. */
static bool read_first_line(int fd, char *line, size_t len) {
  size_t used = 0;
  const long long deadline = now_ms() + START_TIMEOUT_MS;
  while (used + 1u < len) {
    const long long left = deadline - now_ms();
    if (left <= 0) {
      return false;
    }
    struct pollfd p = {.fd = fd, .events = POLLIN};
    const int ready = poll(&p, 1, (int)left);
    if (ready < 0 && errno == EINTR) {
      continue;
    }
    if (ready <= 0) {
      return false;
    }
    const ssize_t n = read(fd, line + used, 1);
    if (n <= 0) {
      return false; /* it exited: it said why on stderr */
    }
    if (line[used] == '\n') {
      line[used] = '\0';
      return true;
    }
    used++;
  }
  return false;
}

int emu_dashboard_start(emu_dashboard_t *d, const char *control_path, const char *listen, char *err, size_t err_len) {
  memset(d, 0, sizeof(*d));
  d->out_fd = -1;
  char python[4096];
  const char *env_python = getenv("AX12_PYTHON");
  snprintf(python, sizeof python, "%s", env_python && *env_python ? env_python : AX12_REPO_DIR "/.venv/bin/python");
  const char *script = AX12_REPO_DIR "/scripts/ax12_dashboard.py";
  int out[2];
  if (pipe2(out, O_CLOEXEC) != 0) {
    snprintf(err, err_len, "dashboard: %s", strerror(errno));
    return -1;
  }
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) {
    snprintf(err, err_len, "dashboard: %s", strerror(errno));
    close(out[0]);
    close(out[1]);
    return -1;
  }
  if (pid == 0) {
    /* The child: only async-signal-safe calls until exec. */
    prctl(PR_SET_PDEATHSIG, SIGTERM); /* the emulator killed: the dashboard goes too */
    if (getppid() != parent) {
      _exit(1);
    }
    dup2(out[1], STDOUT_FILENO);
    char *argv[] = {python, (char *)script, "--control", (char *)control_path, "--listen", (char *)listen,
                    "--build", AX12_BUILD_DIR, NULL};
    execv(python, argv);
    static const char failed[] = "ax12-emu: --dashboard: cannot run the project's Python (scripts/setup makes it)\n";
    (void)!write(STDERR_FILENO, failed, sizeof failed - 1u);
    _exit(127);
  }
  close(out[1]);
  d->pid = pid;
  d->out_fd = out[0];
  char line[200];
  if (!read_first_line(d->out_fd, line, sizeof line) || strncmp(line, "listening ", 10) != 0) {
    snprintf(err, err_len, "the dashboard did not start on %s (its messages are above)", listen);
    emu_dashboard_stop(d);
    return -1;
  }
  snprintf(d->url, sizeof d->url, "%s", line + 10);
  return 0;
}

void emu_dashboard_stop(emu_dashboard_t *d) {
  if (d->pid > 0) {
    kill(d->pid, SIGTERM);
    int status;
    while (waitpid(d->pid, &status, 0) < 0 && errno == EINTR) {
    }
    d->pid = 0;
  }
  if (d->out_fd >= 0) {
    close(d->out_fd);
    d->out_fd = -1;
  }
}
