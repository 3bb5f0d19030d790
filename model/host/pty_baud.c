/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "pty_baud.h"

#include <asm/ioctls.h>
#include <asm/termbits.h>

/* <sys/ioctl.h> would drag in <termios.h>-style definitions that clash with asm/termbits.h. */
extern int ioctl(int fd, unsigned long request, ...);

double pty_get_bps(int fd) {
  struct termios2 t;
  if (ioctl(fd, TCGETS2, &t) != 0) {
    return 0.0;
  }
  return (double)t.c_ospeed;
}

int pty_set_bps(int fd, double bps) {
  struct termios2 t;
  if (ioctl(fd, TCGETS2, &t) != 0) {
    return -1;
  }
  t.c_cflag &= ~(unsigned)CBAUD;
  t.c_cflag |= BOTHER;
  t.c_cflag &= ~(unsigned)(CBAUD << IBSHIFT);
  t.c_cflag |= BOTHER << IBSHIFT;
  t.c_ospeed = (speed_t)bps;
  t.c_ispeed = (speed_t)bps;
  return ioctl(fd, TCSETS2, &t) == 0 ? 0 : -1;
}
