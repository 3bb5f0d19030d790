/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "state_file.h"

#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "state_write_behind.h"

int state_file_open(const char *path, off_t *size, char *err, size_t err_len) {
  /* O_NONBLOCK: opening a FIFO must not wait for a writer; it is refused below. */
  const int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) {
    if (errno == ENOENT) {
      return STATE_FILE_ABSENT;
    }
    snprintf(err, err_len, "cannot read %s: %s", path, strerror(errno));
    return -1;
  }
  struct stat st;
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    snprintf(err, err_len, "%s is not a regular file", path);
    close(fd);
    return -1;
  }
  *size = st.st_size;
  return fd;
}

static int write_all(int fd, const uint8_t *data, size_t size) {
  size_t done = 0;
  while (done < size) {
    const ssize_t n = write(fd, data + done, size - done);
    if (n < 0 && errno == EINTR) {
      continue;
    }
    if (n <= 0) {
      return -1;
    }
    done += (size_t)n;
  }
  return 0;
}

int state_file_replace(const char *path, const void *data, size_t size, char *err, size_t err_len) {
  if (state_write_behind_active()) {
    return state_write_behind_queue(path, data, size, err, err_len);
  }
  return state_file_replace_now(path, data, size, err, err_len);
}

int state_file_replace_now(const char *path, const void *data, size_t size, char *err, size_t err_len) {
  char tmp[4096];
  if (snprintf(tmp, sizeof(tmp), "%s.tmp.%ld", path, (long)getpid()) >= (int)sizeof(tmp)) {
    snprintf(err, err_len, "state file path too long: %s", path);
    return -1;
  }
  const int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    snprintf(err, err_len, "cannot write %s: %s", tmp, strerror(errno));
    return -1;
  }
  /* No fsync: write + rename is atomic against the emulator being killed (the kernel keeps
   * what was written), which is the durability a state file needs; fsync, which guards only
   * against the host machine itself crashing, stalled real-time pacing by up to 130 ms per
   * EEPROM byte on a disk. */
  if (write_all(fd, data, size) != 0) {
    snprintf(err, err_len, "cannot write %s: %s", tmp, strerror(errno));
    close(fd);
    unlink(tmp);
    return -1;
  }
  close(fd);
  if (rename(tmp, path) != 0) {
    snprintf(err, err_len, "cannot replace %s: %s", path, strerror(errno));
    unlink(tmp);
    return -1;
  }
  return 0;
}
