/* SPDX-License-Identifier: GPL-3.0-or-later */
/* One servo's firmware opened to avr-gdb (docs/debugging.md): simavr's gdb stub on a TCP
 * port of 127.0.0.1, served from the world's loop (simavr_patch.h "the gdb stub").
 *
 * The servo runs until gdb stops it: when gdb attaches, at a breakpoint or a watchpoint, on
 * Ctrl-C and after each step. While gdb holds it (servo_gdb_holds), servo_gdb_run_until()
 * does not advance it, and the world (world_set_debugged) advances nobody: the bus is
 * lockstep, so simulated time stands still for every servo and host node until gdb
 * continues. A stop inside a world step ends the step there, the other servos running to the
 * same cycle.
 *
 * The servo runs one instruction at a time (after each, its PC is checked against gdb's
 * breakpoints, and a watchpoint's stop is seen), slower than in batches; the others are not
 * affected. Continuing a core that gdb stopped asleep puts it back to sleep (simavr's stub
 * would wake it); a step (stepi) executes the instruction at the PC even when the core was
 * asleep, as simavr's own gdb mode does. Closing the connection (gdb's detach, kill or exit)
 * clears the breakpoints and lets the servo run on. */
#ifndef SIM_SERVO_GDB_H
#define SIM_SERVO_GDB_H

#include <stdbool.h>
#include <stddef.h>

#include "servo.h"
#include "sim_time.h"

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

/* Runs the servo toward t as servo_run_until does, for the world (world_set_debugged): nothing
 * while gdb holds it; otherwise the core runs an instruction a call to servo_run_until (a
 * sleeping one to its next cycle timer), and after each the PC is checked against gdb's
 * breakpoints and a watchpoint's stop is taken: it stops there (the stop reported to gdb),
 * before t. servo_run_until itself knows nothing of gdb (it costs the other servos nothing):
 * it must not be called on this servo while gdb holds it, unless its clock is at or past the
 * time asked (then it returns at once), which the world ensures. */
void servo_gdb_run_until(servo_t *servo, sim_cycles_t t);

#endif
