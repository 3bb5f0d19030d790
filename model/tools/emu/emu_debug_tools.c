/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_debug_tools.h"

#include <stdio.h>
#include <string.h>

#include "emu_stop_signal.h"

static size_t servo_index_of(const serve_options_t *o, uint8_t id) {
  for (size_t i = 0; i < o->id_count; i++) {
    if (o->ids[i] == id) {
      return i;
    }
  }
  return 0; /* the parser checked every ID against --ids */
}

bool emu_debug_open(emu_debug_tools_t *d, world_t *world, const serve_options_t *o, char *err, size_t err_len) {
  memset(d, 0, sizeof(*d));
  if (o->trace_path) {
    bool traced[WORLD_MAX_SERVOS];
    for (size_t i = 0; i < world->servo_count; i++) {
      traced[i] = o->trace_id_count == 0;
    }
    for (size_t i = 0; i < o->trace_id_count; i++) {
      traced[servo_index_of(o, o->trace_ids[i])] = true;
    }
    d->trace = world_trace_open(world, o->trace_path, traced, err, err_len);
    if (!d->trace) {
      return false;
    }
    d->trace_path = o->trace_path;
    d->trace_flush_at_us = pacing_wall_us() + EMU_DEBUG_TRACE_FLUSH_US;
  }
  if (o->gdb) {
    servo_t *servo = world->servos[servo_index_of(o, o->gdb_id)];
    if (!servo_gdb_open(&d->gdb, servo, o->gdb_port, err, err_len)) {
      return false;
    }
    d->gdb_open = true;
    world_set_debugged(world, servo);
    fprintf(stderr,
            "ax12-emu: servo %u (%s): gdb on 127.0.0.1:%u: avr-gdb %s -ex 'target remote :%u'; it runs until gdb "
            "attaches; while gdb holds it, the whole bus stands still\n",
            o->gdb_id, servo->name, o->gdb_port, o->elf, o->gdb_port);
  }
  if (d->trace) {
    fprintf(stderr, "ax12-emu: tracing %zu servo%s to %s\n", d->trace->count, d->trace->count == 1 ? "" : "s",
            o->trace_path);
  }
  return true;
}

void emu_debug_after_run(emu_debug_tools_t *d) {
  if (d->trace) {
    world_trace_commit(d->trace);
    const double wall = pacing_wall_us();
    if (wall >= d->trace_flush_at_us) {
      (void)world_trace_flush(d->trace);
      d->trace_flush_at_us = wall + EMU_DEBUG_TRACE_FLUSH_US;
    }
  }
  if (d->gdb_open) {
    servo_gdb_poll(&d->gdb, 0);
  }
}

void emu_debug_wait_while_held(emu_debug_tools_t *d, world_t *world, pacing_t *pacing) {
  if (!d->gdb_open || !world_held(world)) {
    return;
  }
  fprintf(stderr, "ax12-emu: gdb holds %s at pc 0x%04x, %.6f s simulated: the bus stands still\n",
          d->gdb.servo->name, servo_gdb_pc(&d->gdb), sim_cycles_to_us(world->now) / 1e6);
  if (d->trace) {
    (void)world_trace_flush(d->trace);
  }
  while (!emu_stop_requested() && world_held(world)) {
    servo_gdb_poll(&d->gdb, EMU_DEBUG_GDB_WAIT_US);
  }
  pacing_resume(pacing, world->now);
}

void emu_debug_close_gdb(emu_debug_tools_t *d) {
  if (d->gdb_open) {
    servo_gdb_close(&d->gdb);
    d->gdb_open = false;
  }
}

bool emu_debug_close_trace(emu_debug_tools_t *d, const world_t *world, bool report) {
  if (!d->trace) {
    return true;
  }
  const unsigned long long changes = d->trace->changes;
  const size_t servos = d->trace->count;
  const int closed = world_trace_close(d->trace);
  d->trace = NULL;
  if (closed != 0) {
    fprintf(stderr, "ax12-emu: the trace %s could not be written whole\n", d->trace_path);
    return false;
  }
  if (!report) {
    return true;
  }
  fprintf(stderr, "ax12-emu: trace %s: %zu servo%s, %.3f s simulated, %llu value changes\n", d->trace_path, servos,
          servos == 1 ? "" : "s", sim_cycles_to_us(world->now) / 1e6, changes);
  return true;
}
