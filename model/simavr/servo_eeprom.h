/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A servo's EEPROM: write timing as on silicon, and persistence to its state file
 * (model/host/eeprom_store.h).
 *
 * Write timing (simavr 1.6 workaround): simavr stores a byte the moment the firmware sets
 * EEPE (with EEMPE) and raises EE_READY 3.4 ms later, but clears EEPE at once; the servo
 * keeps EEPE set for those 3.4 ms as silicon does (firmware that polls eeprom_is_ready()
 * waits like on a board), and a write started while one is under way is ignored, as silicon
 * ignores it.
 *
 * Persistence: the servo watches EECR. At the end of the world step in which a byte was
 * written (< 10 us of simulated time later) the whole EEPROM is written to the state file,
 * atomically. Any consequence of the write (the reply to a WRITE) needs at least one byte
 * time (10 us at 1 Mbps, more than a step) before it leaves the simulation, so a reply proves
 * persistence, even against SIGKILL. A sequence of byte writes is persisted byte by byte,
 * exactly as the EEPROM holds it, so a kill in the middle of a sequence leaves what a power
 * cut at that moment would leave. */
#ifndef SIM_SERVO_EEPROM_H
#define SIM_SERVO_EEPROM_H

#include <stdbool.h>
#include <stddef.h>

#include "servo.h"
#include "sim_time.h"

/* One EEPROM byte write on the ATmega88/328P: 3.4 ms. */
#define SIM_EEPROM_WRITE_CYCLES ((sim_cycles_t)3400u * SIM_CYCLES_PER_US)
/* Quiet time after the last write completed that ends a write sequence (clean shutdown). */
#define SERVO_EEPROM_QUIET ((sim_cycles_t)1000u * SIM_CYCLES_PER_US)

/* At servo_create: finds simavr's EEPROM, fills it from config (an explicit image, the state
 * file, or a seeded factory image, saved at once) and hooks EECR. -1 with err set. */
int servo_eeprom_attach(servo_t *servo, const servo_config_t *config, char *err, size_t err_len);

/* The MCU was reset: simavr dropped the write-completion timer (it stored the byte already). */
void servo_eeprom_was_reset(servo_t *servo);

/* Persists the EEPROM if a byte was written since the last time. Returns -1 when a write
 * failed (message in last_error), 1 when written, 0 otherwise. */
int servo_poll_persist(servo_t *servo);

/* Persists now if the EEPROM differs from the file. Same returns. */
int servo_persist(servo_t *servo);

/* True while a write sequence may be under way: a write not persisted or not finished, or
 * finished less than SERVO_EEPROM_QUIET ago. */
bool servo_eeprom_unsettled(const servo_t *servo, sim_cycles_t now);

#endif
