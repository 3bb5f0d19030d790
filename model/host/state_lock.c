/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "state_lock.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <stdbool.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

/* "<state_path>.lock" in out; false when it does not fit. */
static bool lock_path(char *out, size_t out_len, const char *state_path) {
  return snprintf(out, out_len, "%s.lock", state_path) < (int)out_len;
}

/* True when fd is still the file path names (not removed or replaced since it was opened). */
static bool still_named(int fd, const char *path) {
  struct stat opened, named;
  return fstat(fd, &opened) == 0 && stat(path, &named) == 0 && opened.st_dev == named.st_dev &&
         opened.st_ino == named.st_ino;
}

#define TAKE_ATTEMPTS 100

int state_lock_take(const char *state_path, char *err, size_t err_len) {
  char path[4200];
  if (!lock_path(path, sizeof path, state_path)) {
    snprintf(err, err_len, "state file path too long: %s", state_path);
    return -1;
  }
  for (int attempt = 0; attempt < TAKE_ATTEMPTS; attempt++) {
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
    if (!still_named(fd, path)) {
      close(fd); /* its holder removed it on release: take the new one */
      continue;
    }
    char text[32];
    const int len = snprintf(text, sizeof text, "%ld\n", (long)getpid());
    if (ftruncate(fd, 0) != 0 || pwrite(fd, text, (size_t)len, 0) != len) {
      /* The lock holds without the PID; only the message of a second emulator is poorer. */
    }
    return fd;
  }
  snprintf(err, err_len, "cannot lock %s: its lock file keeps being replaced", state_path);
  return -1;
}

void state_lock_release(int fd, const char *state_path) {
  if (fd < 0) {
    return;
  }
  char path[4200];
  if (lock_path(path, sizeof path, state_path) && still_named(fd, path)) {
    (void)unlink(path);
  }
  close(fd);
}
