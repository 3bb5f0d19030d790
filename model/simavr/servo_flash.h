/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A servo's flash under self-programming (SPM, a bootloader's update): its timing as on
 * silicon, and persistence to the state file `servo-<n>.flash` (model/host/flash_store.h).
 *
 * simavr 1.6 (avr_flash.c) implements the ATmega88/328P's SPM: the page buffer fill (each word
 * once until the buffer is cleared), page erase, page write (the buffer is cleared after it)
 * and RWWSRE (clears the buffer); it ignores BLBSET. Each operation completes within the SPM
 * instruction and clears SPMEN there. Workarounds here (docs/emulator.md "simavr 1.6
 * workarounds"):
 *   - busy time: after a page erase or page write SPMEN stays set for SERVO_SPM_BUSY_CYCLES
 *     (4.0 ms; silicon: 3.7-4.5 ms), so a bootloader that polls SPMEN waits as on a board;
 *     meanwhile an SPM is ignored and an SPMCSR write changes SPMIE only. The page holds its
 *     new bytes from the SPM on (silicon's page is undefined until the end: a power cut inside
 *     those 4 ms is a cut just after the SPM here). The CPU runs on during an erase or write
 *     of an NRWW page, where silicon halts it; a bootloader polling SPMEN sees the same.
 *   - RWWSB: set by a page erase or write in the RWW section (below 0x7000 on the ATmega328P,
 *     0x1800 on the ATmega88), cleared by the RWWSRE SPM; simavr never sets it. The RWW
 *     section still reads normally meanwhile (silicon's does not): not modelled.
 *   - addressing: simavr erases the page size's bytes from Z (not from the start of Z's page)
 *     and writes past its flash array for a Z beyond the flash; silicon ignores Z's in-page
 *     bits for both and its bits above the flash size. Z is given to simavr so.
 *   - where: SPM runs only from the boot section (the top BOOT_SECTION_BYTES), as on silicon;
 *     simavr runs it from anywhere.
 *
 * Persistence (the EEPROM's contract, servo_eeprom.h): at the end of the world step in which
 * a page erase or page write changed the flash (less than 10 us of simulated time later), the
 * whole flash and the identity of the build the servo started from are written to the state
 * file atomically. Any consequence of the SPM (the bootloader's answer) needs a byte time on
 * the wire before it leaves the simulation, so an answer proves persistence, even against
 * SIGKILL: a killed emulator leaves the flash a power cut at that moment would leave. A servo
 * whose flash was never changed by SPM has no flash file. */
#ifndef SIM_SERVO_FLASH_H
#define SIM_SERVO_FLASH_H

#include <stddef.h>

#include "servo.h"
#include "sim_time.h"

struct avr_t;
struct avr_flash_t;

/* A page erase or page write: 4.0 ms, the middle of the datasheet's 3.7-4.5 ms. */
#define SERVO_SPM_BUSY_CYCLES ((sim_cycles_t)4000u * SIM_CYCLES_PER_US)

/* simavr's self-programming module of the MCU (page size, SPMCSR), NULL when it has none. */
struct avr_flash_t *servo_flash_module(struct avr_t *avr);

/* At servo_create, the flash as the ELFs load it (servo_boot.h): takes its identity, replaces
 * it with the state file's flash when that file is of this build and this MCU, else removes
 * the file (servo->flash_origin says which), and hooks SPM. -1 with err set. */
int servo_flash_attach(servo_t *servo, const servo_config_t *config, char *err, size_t err_len);

/* After avr_terminate(): frees what servo_flash_attach gave simavr. */
void servo_flash_detach(servo_t *servo);

/* Persists the flash if SPM changed it since the last time: -1 when the write failed
 * (message in last_error; retried at the next call), 1 when written, 0 otherwise. */
int servo_flash_poll_persist(servo_t *servo);

#endif
