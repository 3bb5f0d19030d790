/* SPDX-License-Identifier: GPL-3.0-or-later */
/* One servo's firmware opened to avr-gdb (docs/debugging.md): simavr's gdb stub on a TCP
 * port of 127.0.0.1, served from the world's loop (simavr_patch.h "the gdb stub").
 *
 * The servo runs until gdb stops it: when gdb attaches, at a breakpoint or a watchpoint, on
 * Ctrl-C and after each step. While gdb holds it (servo_gdb_holds), servo_run_until() does
 * not advance it, and the world (world_set_debugged) advances nobody: the bus is lockstep, so
 * simulated time stands still for every servo and host node until gdb continues. A stop
 * inside a world step ends the step there, the other servos running to the same cycle.
 *
 * While gdb has a breakpoint set, the servo runs one instruction a step (its PC is checked
 * after each); without one, in batches as usual. Continuing a core that gdb stopped asleep
 * puts it back to sleep (simavr's stub would wake it); a step (stepi) executes the
 * instruction at the PC even when the core was asleep, as simavr's own gdb mode does.
 * Closing the connection (gdb's detach, kill or exit) clears the breakpoints and lets the
 * servo run on. */
#ifndef SIM_SERVO_GDB_H
#define SIM_SERVO_GDB_H

#include <stdbool.h>
#include <stddef.h>

#include "servo.h"

typedef struct servo_gdb {
  servo_t *servo;
  unsigned port;
  int held_from;   /* the core's state (cpu_Running or cpu_Sleeping) when gdb stopped it */
  bool stepping;   /* one instruction to run for a stepi, then report */
  unsigned long long stops; /* times gdb stopped the servo */
} servo_gdb_t;

/* Opens servo to gdb on 127.0.0.1:port (the servo keeps running). False with err set. */
bool servo_gdb_open(servo_gdb_t *gdb, servo_t *servo, unsigned port, char *err, size_t err_len);

/* Closes the port; a servo gdb held runs on. */
void servo_gdb_close(servo_gdb_t *gdb);

/* Serves gdb, waiting up to wait_us for a connection or a request. */
void servo_gdb_poll(servo_gdb_t *gdb, unsigned wait_us);

/* The core's program counter, a byte address as gdb shows it. */
unsigned servo_gdb_pc(const servo_gdb_t *gdb);

/* True while gdb holds the servo stopped. */
bool servo_gdb_holds(const servo_t *servo);

/* For servo_run_until (servo->gdb set): false while gdb holds the servo (it must not
 * advance); prepares a stepi's one instruction. */
bool servo_gdb_may_run(servo_t *servo);

/* For servo_run_until: true when the batches must be single instructions (a breakpoint is
 * set, or a stepi is under way). */
bool servo_gdb_single_steps(const servo_t *servo);

/* For servo_run_until, after each step: true when the servo must stop here (a stepi done, a
 * breakpoint at the new PC, a watchpoint hit); the stop is reported to gdb. */
bool servo_gdb_after_step(servo_t *servo);

#endif
