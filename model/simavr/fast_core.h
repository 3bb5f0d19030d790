/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The emulator's own AVR instruction interpreter: a pre-decoded replacement for simavr 1.6's
 * avr_run_one() that runs on simavr's avr_t state (registers, SREG mirror, data space, I/O
 * handlers, cycle counter, run_cycle_count) with exactly its semantics and cycle counts, about
 * four times cheaper on the host. Each flash word is decoded once into a handler and its
 * operands; the entry keeps the word it was decoded from and is decoded again when the flash
 * word differs (SPM, a new image, gdb's memory writes): no invalidation to call.
 *
 * What simavr's core does that this one does the same way, by design: I/O registers
 * (0x20..0x136) go through simavr's read/write handlers and raise the register's IRQs when
 * someone asked for them; SREG is simavr's eight-byte mirror; SEI/RETI/OUT SREG delay
 * interrupts as simavr does; invalid opcodes are logged and skipped; a PC past the flash
 * crashes the core. What it leaves to simavr: a core with gdb attached (watchpoints) runs
 * simavr's avr_run_one (fast_core_step_batch decides), and so does an MCU it does not cover
 * (flash over 64 KB or a 3-byte return address).
 *
 * tests/sim test_fast_core checks it against avr_run_one instruction by instruction on random
 * programs; the differential test runs a whole bus both ways (docs/emulator.md "Speed"). */
#ifndef SIM_FAST_CORE_H
#define SIM_FAST_CORE_H

#include <stdbool.h>
#include <stdint.h>

struct avr_t;

typedef struct fast_core fast_core_t;

/* A decoded-instruction cache for avr's flash; NULL when the MCU is one the fast core does not
 * cover (then simavr's interpreter runs it). */
fast_core_t *fast_core_new(const struct avr_t *avr);
void fast_core_free(fast_core_t *core);

/* False when the environment asks for simavr's interpreter (AX12_SIM_CORE=simavr): the
 * reference the differential test and `scripts/bench --before` compare against. */
bool fast_core_wanted(void);

/* Runs instructions as avr_run_one(avr) does: one, then on while the core runs, no interrupt
 * is pending and more than the instruction's cycles are left in avr->run_cycle_count (which
 * it lowers); returns the PC after the last one, with avr->pc left at that instruction.
 * until > 0: the bound of the emulator's step (simavr_step_core); the batch then also goes on
 * through the instructions after SEI/RETI that delay interrupts, where the step would only
 * count the delay down and start a new batch (no cycle timer due, until not reached): the same
 * instructions, cycles and interrupt state, fewer returns. */
uint32_t fast_core_run(fast_core_t *core, struct avr_t *avr, uint64_t until);

/* The part of simavr's avr_service_interrupts() after its checks (simavr_patch_run.h makes
 * them): enters the highest-priority pending interrupt, with this core's stores and without
 * calls for the interrupt IRQs nobody hooks. */
void fast_core_enter_interrupt(struct avr_t *avr);

#endif
