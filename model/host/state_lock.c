/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "state_lock.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/file.h>
#include <unistd.h>

int state_lock_take(const char *state_path, char *err, size_t err_len) {
  char path[4200];
  if (snprintf(path, sizeof path, "%s.lock", state_path) >= (int)sizeof path) {
    snprintf(err, err_len, "state file path too long: %s", state_path);
    return -1;
  }
  const int fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) {
    snprintf(err, err_len, "cannot lock %s: %s", state_path, strerror(errno));
    return -1;
  }
  if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int why = errno;
    char pid[32] = "";
    const ssize_t n = pread(fd, pid, sizeof pid - 1u, 0);
    if (n > 0) {
      pid[n] = '\0';
      pid[strcspn(pid, "\n")] = '\0';
    }
    if (why == EWOULDBLOCK) {
      snprintf(err, err_len, "%s is in use by another ax12-emu (pid %s)", state_path, pid[0] ? pid : "unknown");
    } else {
      snprintf(err, err_len, "cannot lock %s: %s", state_path, strerror(why));
    }
    close(fd);
    return -1;
  }
  char text[32];
  const int len = snprintf(text, sizeof text, "%ld\n", (long)getpid());
  if (ftruncate(fd, 0) != 0 || pwrite(fd, text, (size_t)len, 0) != len) {
    /* The lock holds without the PID; only the message of a second emulator is poorer. */
  }
  return fd;
}

void state_lock_release(int fd) {
  if (fd >= 0) {
    close(fd);
  }
}
