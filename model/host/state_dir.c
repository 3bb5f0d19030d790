/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "state_dir.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static int mkdir_p(const char *path) {
  char buf[PATH_MAX];
  if (snprintf(buf, sizeof(buf), "%s", path) >= (int)sizeof(buf)) {
    errno = ENAMETOOLONG;
    return -1;
  }
  for (char *p = buf + 1; *p; p++) {
    if (*p == '/') {
      *p = '\0';
      if (mkdir(buf, 0755) != 0 && errno != EEXIST) {
        return -1;
      }
      *p = '/';
    }
  }
  if (mkdir(buf, 0755) != 0 && errno != EEXIST) {
    return -1;
  }
  return 0;
}

bool state_dir_usable(const char *dir, char *err, size_t err_len) {
  if (mkdir_p(dir) != 0) {
    snprintf(err, err_len, "state directory %s cannot be created: %s", dir, strerror(errno));
    return false;
  }
  struct stat st;
  if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode)) {
    snprintf(err, err_len, "state directory %s is not a directory", dir);
    return false;
  }
  char probe[PATH_MAX];
  snprintf(probe, sizeof(probe), "%s/.ax12-write-test.%ld", dir, (long)getpid());
  FILE *f = fopen(probe, "w");
  if (!f) {
    snprintf(err, err_len, "state directory %s cannot be written: %s", dir, strerror(errno));
    return false;
  }
  fclose(f);
  unlink(probe);
  return true;
}

void state_dir_default(char *out, size_t len) {
  const char *xdg = getenv("XDG_STATE_HOME");
  if (xdg && xdg[0] == '/') {
    snprintf(out, len, "%s/ax12", xdg);
    return;
  }
  const char *home = getenv("HOME");
  snprintf(out, len, "%s/.local/state/ax12", home && *home ? home : ".");
}
