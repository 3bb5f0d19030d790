/* SPDX-License-Identifier: GPL-3.0-or-later */
/* How `ax12-emu serve` is asked to stop: SIGINT, SIGTERM and SIGHUP set a flag (the handler does
 * nothing else) that the serve loop and the wait while gdb holds the world read; SIGPIPE is
 * ignored, so a reader gone (the control socket's, the dashboard's) is a failed write, not the
 * end of the process. */
#ifndef EMU_STOP_SIGNAL_H
#define EMU_STOP_SIGNAL_H

#include <stdbool.h>

/* Installs the handlers (once, before the serve loop). */
void emu_stop_signal_install(void);

/* True once one of the three signals came. */
bool emu_stop_requested(void);

#endif
