/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Every place the emulator reaches past simavr 1.6's public API into its internals, in one
 * module: the I/O register handler table, the cycle-timer list, the core's run loop, the
 * external-interrupt module's private poll timers, the USART's read-rate limiter and the list
 * of pending interrupts. Each of these exists because simavr 1.6 models the chip imperfectly
 * or too slowly for a bus of servos (docs/emulator.md "simavr 1.6 workarounds" lists the
 * callers and why); a simavr upgrade starts here. This header declares the module without simavr's headers; the run
 * loop, inline because it is the emulator's innermost loop, is in simavr_patch_run.h. */
#ifndef SIM_SIMAVR_PATCH_H
#define SIM_SIMAVR_PATCH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "sim_time.h"

struct avr_t;
struct avr_uart_t;

/* ---- I/O register handlers (avr->io[]) ----
 * simavr 1.6's public calls (avr_register_io_read/write) give no way to wrap the handler a
 * register has: call it from the new one, or not (the EECR hook must not let simavr store a
 * byte silicon ignores), so the handler table is edited here.
 * A write hook replaces the register's handler and keeps the one it replaced, so the new
 * handler can chain to it; a read or write takeover replaces it for good. Users: the EECR
 * hook (servo_eeprom.c), the USART (uart_link.c), Timer0 (quiet_timer.c). */

typedef uint8_t (*io_read_fn)(struct avr_t *avr, uint16_t addr, void *param);
typedef void (*io_write_fn)(struct avr_t *avr, uint16_t addr, uint8_t v, void *param);

/* The handler a write hook replaced (c NULL: there was none; simavr stored the byte). */
typedef struct {
  io_write_fn c;
  void *param;
} io_write_hook_t;

/* Installs fn(param) as the write handler of addr; *replaced receives the previous one. */
void io_hook_write(struct avr_t *avr, uint16_t addr, io_write_fn fn, void *param, io_write_hook_t *replaced);

/* What the replaced handler would have done with the write: call it, or store the byte. */
void io_hook_chain(const io_write_hook_t *replaced, struct avr_t *avr, uint16_t addr, uint8_t v);

/* Installs fn(param) as the read / write handler of addr, replacing simavr's for good. */
void io_take_read(struct avr_t *avr, uint16_t addr, io_read_fn fn, void *param);
void io_take_write(struct avr_t *avr, uint16_t addr, io_write_fn fn, void *param);

/* True when simavr has a read handler for addr. */
bool io_has_read(const struct avr_t *avr, uint16_t addr);

/* ---- the cycle-timer list (avr->cycle_timers) ---- */

/* simavr_first_timer_when_except(): simavr_patch_run.h. */

/* Cancels every cycle timer registered with param `owner`; returns how many. */
unsigned simavr_cancel_timers_of(struct avr_t *avr, const void *owner);

/* ---- the run loop (avr->run, avr->sleep) ---- */

/* Installs simavr_step_core(avr, NULL, 0) (simavr_patch_run.h) as the core's run callback and a
 * sleep callback that does nothing: the world paces itself, and servo_run.c moves a sleeping
 * core's clock itself (simavr's sleep would only jump the clock, one cycle late). */
void simavr_install_run_loop(struct avr_t *avr);

/* simavr 1.6's watchdog asks for its reset by replacing avr->run with a callback that calls
 * avr_reset() (which puts the run callback back): the batches of servo_run.c never call
 * avr->run, so they take the reset when this is true (servo_reset). */
bool simavr_reset_requested(const struct avr_t *avr);

/* ---- the external-interrupt module (avr_extint.c) ---- */

/* simavr 1.6 polls a level-triggered INT0/INT1 pin on every cycle while it is low, whether or
 * not the interrupt is enabled. INT0 is PD2, the direction pin, low whenever a servo listens:
 * that poll made the simulation ~50x slower. Switches the strict level mode off and cancels a
 * poll already running (the firmware uses neither INT0 nor INT1). simavr turns the strict mode
 * back on at every reset: call again after one (board.c does). */
void simavr_extint_poll_off(struct avr_t *avr);

/* ---- the USART (avr_uart.c) ---- */

/* simavr 1.6 limits how fast UDR0 may be read after RXC rises (rx_cnt / rxc_raise_time) and
 * clears RXC early when the firmware reads faster than its own byte pacing; a byte placed in
 * the FIFO by the bus model resets that limiter, so RXC stays raised while bytes wait. */
void simavr_uart_rx_limiter_reset(struct avr_uart_t *uart);

/* ---- the pending-interrupt list (avr->interrupts.pending) ----
 * simavr 1.6 keeps a vector in that list after it is cleared (it only marks it not pending)
 * and takes entries out only while interrupts are enabled; with them off for long (a
 * bootloader with an application's Timer1 interrupts left enabled) the 63 places fill, and a
 * vector raised then is marked pending without being listed: it never interrupts again. When
 * the list is full, drops its entries that are no longer pending (and repeats). Called before
 * the USART's raises (uart_link.c). */
void simavr_interrupts_make_room(struct avr_t *avr);

/* ---- the gdb stub (sim_gdb.c) ----
 * simavr 1.6's stub (avr_gdb_init, avr_gdb_processor) is made for its own run loop, which
 * the world does not use: the stub's listening socket, its connection and its breakpoint
 * list are private to sim_gdb.c, so the world's loop reads them here (the struct's 1.6
 * layout, checked after init). Also: the stub listens on every interface (here: replaced
 * by a socket on 127.0.0.1 only), prints on stdout (here: its calls run with stdout sent to
 * stderr, since the emulator's stdout carries only its ready line), installs its own
 * run and sleep callbacks (here: simavr_install_run_loop's are put back) and does not know
 * gdb's detach packet (here: answered, the connection then ended as when gdb closes it). */

/* Opens the stub on 127.0.0.1:port. False with err set (port in use...). */
bool simavr_gdb_open(struct avr_t *avr, unsigned port, char *err, size_t err_len);

/* Closes the stub (and a connection); the core's state is left as it is. */
void simavr_gdb_close(struct avr_t *avr);

/* Waits up to wait_us for gdb (a connection, a request, Ctrl-C, a detach) and serves what came,
 * as avr_gdb_processor does: a stop to report (cpu_StepDone) is sent first. Breakpoints are the
 * caller's to find (simavr_gdb_breakpoint_at after each instruction, then
 * simavr_gdb_report_stop). Returns true when something was served. */
bool simavr_gdb_serve(struct avr_t *avr, unsigned wait_us);

/* Reports a stop to gdb at once (a breakpoint was reached: the core stops there). */
void simavr_gdb_report_stop(struct avr_t *avr);

/* True when gdb has a breakpoint at byte address pc / any breakpoint. */
bool simavr_gdb_breakpoint_at(const struct avr_t *avr, uint32_t pc);
bool simavr_gdb_has_breakpoints(const struct avr_t *avr);

#endif
