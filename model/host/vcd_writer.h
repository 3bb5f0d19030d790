/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A Value Change Dump file (the IEEE 1364 text format GTKWave opens) written while a
 * simulation runs: the header and the variables (1-bit wires and vectors up to 32 bits, in
 * nested scopes) are declared first, then value changes are added in time order.
 *
 * Time is in simulated 16 MHz cycles (sim_time.h); the file's timescale is 100 ps, so a cycle
 * is exactly 625 time units. Only changes are written: a value equal to the variable's last
 * one is dropped, and a time stamp is written only before the first change at that time.
 *
 * The file on disk always ends on a whole line: text collects in a buffer that goes out with
 * write(2) only at a line boundary (when it passes VCD_WRITER_BUFFER bytes, or at
 * vcd_writer_flush). So after a kill the file is a valid VCD up to the last flush; after
 * vcd_writer_close it is complete, its last time stamp the end time given there. */
#ifndef SIM_VCD_WRITER_H
#define SIM_VCD_WRITER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "sim_time.h"

#define VCD_WRITER_BUFFER 65536u
#define VCD_TIME_UNITS_PER_CYCLE 625u /* 62.5 ns per 16 MHz cycle, in 100 ps units */
#define VCD_WRITER_MAX_VARS 65536u

typedef struct {
  uint32_t value;
  uint8_t width;  /* bits, 1..32 */
  bool written;   /* a value was written (the initial dump counts) */
} vcd_var_t;

typedef struct {
  int fd;
  char *buf;
  size_t len;
  vcd_var_t *vars;
  size_t var_count, var_cap;
  unsigned scope_depth;
  bool in_body;       /* $enddefinitions written */
  bool time_written;  /* a time stamp was written */
  sim_cycles_t last_time;
  uint64_t bytes_written; /* to the file so far */
  int error;              /* the first errno of a failed write; 0 = none */
} vcd_writer_t;

/* Creates (truncates) path and writes the header ($date, $version, $timescale 100 ps).
 * Returns 0, or -1 with err set. */
int vcd_writer_open(vcd_writer_t *w, const char *path, const char *version, char *err, size_t err_len);

/* Declarations, before vcd_writer_begin: a scope (nested until its end), and a variable of
 * width bits (1..32) in the current scope; returns the variable's index (0, 1, 2...) or -1. */
void vcd_writer_scope(vcd_writer_t *w, const char *name);
void vcd_writer_scope_end(vcd_writer_t *w);
int vcd_writer_var(vcd_writer_t *w, const char *name, unsigned width);

/* Ends the declarations and dumps every variable's initial value (set with
 * vcd_writer_initial before this call; 0 otherwise) at time t. */
void vcd_writer_initial(vcd_writer_t *w, int var, uint32_t value);
void vcd_writer_begin(vcd_writer_t *w, sim_cycles_t t);

/* var takes value at time t (t never before the previous change's). */
void vcd_writer_change(vcd_writer_t *w, sim_cycles_t t, int var, uint32_t value);

/* Writes out what is buffered (whole lines). Returns 0, or -1 after a failed write (errno in
 * w->error; later writes are dropped). */
int vcd_writer_flush(vcd_writer_t *w);

/* Writes a last time stamp at end (if later than the last change), flushes and closes.
 * Returns 0, or -1 when a write failed at any point. */
int vcd_writer_close(vcd_writer_t *w, sim_cycles_t end);

#endif
