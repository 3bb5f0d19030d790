/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The line speed of a pseudo-terminal through termios2 (TCGETS2 / TCSETS2), exact also for
 * rates without a Bxxx constant (250000, 57142...). Separate from pty_bridge.c because
 * <asm/termbits.h> and <termios.h> cannot share a translation unit. */
#ifndef SIM_PTY_BAUD_H
#define SIM_PTY_BAUD_H

/* The output speed in bit/s set on the terminal fd refers to (either side of a pty), or 0. */
double pty_get_bps(int fd);

/* Sets input and output speed (BOTHER). Returns 0 or -1. */
int pty_set_bps(int fd, double bps);

#endif
