/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "servo_gdb.h"

#include <string.h>

#include <sim_avr.h>

#include "servo_run.h"
#include "simavr_patch.h"
#include "simavr_patch_run.h"

static bool state_held(int state) { return state == cpu_Stopped || state == cpu_StepDone; }

bool servo_gdb_open(servo_gdb_t *gdb, servo_t *servo, unsigned port, char *err, size_t err_len) {
  memset(gdb, 0, sizeof(*gdb));
  if (!simavr_gdb_open(servo->avr, port, err, err_len)) {
    return false;
  }
  gdb->servo = servo;
  gdb->port = port;
  gdb->held_from = cpu_Running;
  servo->gdb = gdb;
  return true;
}

/* gdb let the core go (continue, detach): back to sleep if it was asleep. */
static void released(servo_gdb_t *gdb) {
  avr_t *avr = gdb->servo->avr;
  if (avr->state == cpu_Running && gdb->held_from == cpu_Sleeping) {
    avr->state = cpu_Sleeping;
  }
}

void servo_gdb_close(servo_gdb_t *gdb) {
  if (!gdb->servo) {
    return;
  }
  avr_t *avr = gdb->servo->avr;
  simavr_gdb_close(avr);
  if (state_held(avr->state) || avr->state == cpu_Step) {
    avr->state = cpu_Running;
    released(gdb);
  }
  gdb->servo->gdb = NULL;
  gdb->servo = NULL;
}

void servo_gdb_poll(servo_gdb_t *gdb, unsigned wait_us) {
  avr_t *avr = gdb->servo->avr;
  const int before = avr->state;
  if (!simavr_gdb_serve(avr, wait_us)) {
    return;
  }
  const int after = avr->state;
  if (!state_held(before) && before != cpu_Step && state_held(after)) {
    gdb->held_from = before; /* attach or Ctrl-C */
    gdb->stops++;
  } else if (state_held(before) && after == cpu_Running) {
    released(gdb); /* continue or detach */
  } else if (before == cpu_Sleeping && after == cpu_Running) {
    avr->state = cpu_Sleeping; /* gdb went away while the core slept: the stub sets Running */
  }
}

unsigned servo_gdb_pc(const servo_gdb_t *gdb) { return (unsigned)gdb->servo->avr->pc; }

bool servo_gdb_holds(const servo_t *servo) { return servo->gdb && state_held(servo->avr->state); }

/* False while gdb holds the core; a stepi's instruction becomes one to run. */
static bool may_run(servo_gdb_t *gdb) {
  avr_t *avr = gdb->servo->avr;
  if (avr->state == cpu_Step) {
    gdb->stepping = true;
    avr->state = cpu_Running;
    return true;
  }
  return !state_held(avr->state);
}

/* After an instruction: true when the servo stops here (a stepi done, a watchpoint hit, a
 * breakpoint at the new PC); the stop is reported to gdb. */
static bool stops_here(servo_gdb_t *gdb) {
  avr_t *avr = gdb->servo->avr;
  if (gdb->stepping) {
    gdb->stepping = false;
    gdb->held_from = avr->state == cpu_Sleeping ? cpu_Sleeping : cpu_Running;
    simavr_gdb_report_stop(avr);
    return true;
  }
  if (state_held(avr->state)) { /* a watchpoint (simavr reported it) */
    gdb->held_from = cpu_Running;
    gdb->stops++;
    return true;
  }
  if (avr->state == cpu_Running && simavr_gdb_breakpoint_at(avr, avr->pc)) {
    gdb->held_from = cpu_Running;
    gdb->stops++;
    simavr_gdb_report_stop(avr);
    return true;
  }
  return false;
}

void servo_gdb_run_until(servo_t *servo, sim_cycles_t t) {
  servo_gdb_t *gdb = servo->gdb;
  avr_t *avr = servo->avr;
  while (!servo->halted && avr->cycle < t && may_run(gdb)) {
    sim_cycles_t to = avr->cycle + 1u; /* a running core: one instruction */
    if (avr->state == cpu_Sleeping && !avr->interrupt_state) {
      const sim_cycles_t next = simavr_first_timer_when(avr);
      to = next >= t ? t : (next > avr->cycle ? next : avr->cycle + 1u);
    }
    servo_run_until(servo, to);
    if (stops_here(gdb)) {
      return;
    }
  }
}
