/* SPDX-License-Identifier: GPL-3.0-or-later */
/* simavr's messages: errors go to stderr prefixed "simavr: ", chatter is dropped (stdout
 * belongs to the program: `ax12-emu serve` prints exactly one line there). */
#ifndef SIM_LOG_H
#define SIM_LOG_H

/* Installs the logger (idempotent). SIM_LOG_LEVEL in the environment (0..5, simavr's
 * LOG_*) raises the verbosity. */
void sim_log_install(void);

#endif
