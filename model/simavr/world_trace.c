/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "world_trace.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define VCD_VERSION "ax12-emu (Open AX-12): the servos' pins in simavr"

/* "servo-3" -> "servo_3": VCD scope names are identifiers. */
static void scope_name(const char *name, char *out, size_t len) {
  snprintf(out, len, "%s", name);
  for (char *c = out; *c; c++) {
    if (!((*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9'))) {
      *c = '_';
    }
  }
}

static void free_trace(world_trace_t *wt) {
  for (size_t i = 0; i < wt->count; i++) {
    servo_trace_detach(&wt->traces[i]);
  }
  free(wt->traces);
  free(wt->var_base);
  free(wt->scratch);
  free(wt);
}

world_trace_t *world_trace_open(world_t *world, const char *path, const bool *traced, char *err, size_t err_len) {
  world_trace_t *wt = calloc(1, sizeof(*wt));
  if (wt) {
    wt->traces = calloc(world->servo_count ? world->servo_count : 1u, sizeof(*wt->traces));
    wt->var_base = calloc(world->servo_count ? world->servo_count : 1u, sizeof(*wt->var_base));
  }
  if (!wt || !wt->traces || !wt->var_base) {
    snprintf(err, err_len, "out of memory");
    if (wt) {
      free(wt->traces);
      free(wt->var_base);
      free(wt);
    }
    return NULL;
  }
  wt->world = world;
  wt->committed = world->now;
  if (vcd_writer_open(&wt->vcd, path, VCD_VERSION, err, err_len) != 0) {
    free_trace(wt);
    return NULL;
  }
  for (size_t i = 0; i < world->servo_count; i++) {
    if (traced && !traced[i]) {
      continue;
    }
    servo_t *servo = world->servos[i];
    if (!servo_trace_attach(&wt->traces[wt->count], servo, err, err_len)) {
      (void)vcd_writer_close(&wt->vcd, world->now);
      free_trace(wt);
      return NULL;
    }
    char scope[40];
    scope_name(servo->name, scope, sizeof(scope));
    vcd_writer_scope(&wt->vcd, scope);
    for (unsigned s = 0; s < SERVO_TRACE_SIGNALS; s++) {
      const int var = vcd_writer_var(&wt->vcd, servo_trace_signals[s].name, servo_trace_signals[s].width);
      vcd_writer_initial(&wt->vcd, var, servo_trace_signals[s].initial);
      if (s == 0) {
        wt->var_base[wt->count] = var;
      }
    }
    vcd_writer_scope_end(&wt->vcd);
    wt->count++;
  }
  vcd_writer_begin(&wt->vcd, world->now);
  if (vcd_writer_flush(&wt->vcd) != 0) {
    snprintf(err, err_len, "cannot write %s: %s", path, strerror(wt->vcd.error));
    (void)vcd_writer_close(&wt->vcd, world->now);
    free_trace(wt);
    return NULL;
  }
  return wt;
}

static int entry_order(const void *a, const void *b) {
  const world_trace_entry_t *x = a, *y = b;
  if (x->event.at != y->event.at) {
    return x->event.at < y->event.at ? -1 : 1;
  }
  if (x->servo != y->servo) {
    return x->servo < y->servo ? -1 : 1;
  }
  return x->event.seq < y->event.seq ? -1 : (x->event.seq > y->event.seq);
}

static bool scratch_room(world_trace_t *wt, size_t need) {
  if (need <= wt->scratch_cap) {
    return true;
  }
  size_t cap = wt->scratch_cap ? wt->scratch_cap : 4096u;
  while (cap < need) {
    cap *= 2u;
  }
  world_trace_entry_t *grown = realloc(wt->scratch, cap * sizeof(*grown));
  if (!grown) {
    return false;
  }
  wt->scratch = grown;
  wt->scratch_cap = cap;
  return true;
}

/* Writes every event before `limit` (SIM_CYCLES_NEVER: all), in time order. */
static void commit_before(world_trace_t *wt, sim_cycles_t limit) {
  size_t n = 0;
  for (size_t i = 0; i < wt->count; i++) {
    servo_trace_t *tr = &wt->traces[i];
    servo_trace_advance(tr, limit == SIM_CYCLES_NEVER ? wt->world->now : limit - 1u);
    if (!scratch_room(wt, n + tr->count)) {
      tr->out_of_memory = true;
      continue;
    }
    size_t kept = 0;
    for (size_t e = 0; e < tr->count; e++) {
      if (tr->events[e].at < limit) {
        wt->scratch[n++] = (world_trace_entry_t){.event = tr->events[e], .servo = (uint32_t)i};
      } else {
        tr->events[kept++] = tr->events[e];
      }
    }
    tr->count = kept;
  }
  qsort(wt->scratch, n, sizeof(*wt->scratch), entry_order);
  for (size_t k = 0; k < n; k++) {
    const world_trace_entry_t *e = &wt->scratch[k];
    vcd_writer_change(&wt->vcd, e->event.at, wt->var_base[e->servo] + (int)e->event.signal, e->event.value);
  }
  wt->changes += n;
  if (limit != SIM_CYCLES_NEVER) {
    wt->committed = limit;
  }
}

void world_trace_commit(world_trace_t *wt) {
  sim_cycles_t limit = wt->world->now;
  const sim_cycles_t on_wire = bus_first_pending_start(&wt->world->bus);
  if (on_wire < limit) {
    limit = on_wire;
  }
  if (limit > wt->committed) {
    commit_before(wt, limit);
  }
}

int world_trace_flush(world_trace_t *wt) {
  world_trace_commit(wt);
  return vcd_writer_flush(&wt->vcd);
}

int world_trace_close(world_trace_t *wt) {
  if (!wt) {
    return 0;
  }
  commit_before(wt, SIM_CYCLES_NEVER);
  bool lost = false;
  for (size_t i = 0; i < wt->count; i++) {
    lost |= wt->traces[i].out_of_memory;
  }
  const int closed = vcd_writer_close(&wt->vcd, wt->world->now);
  free_trace(wt);
  return closed == 0 && !lost ? 0 : -1;
}
