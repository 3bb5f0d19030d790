/* SPDX-License-Identifier: GPL-3.0-or-later */
/* `ax12-emu serve`'s command line: the options, their defaults and checks, and the usage
 * text (docs/emulator.md "Running it"). */
#ifndef EMU_OPTIONS_H
#define EMU_OPTIONS_H

#include <limits.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "eeprom_store.h"
#include "id_list.h"
#include "plant_options.h"
#include "usb_adapter.h"

/* Exit status for bad command-line input. */
#define EMU_EXIT_USAGE 2

typedef struct {
  uint8_t ids[ID_LIST_MAX_ID + 1u];
  size_t id_count;
  const char *link;
  char state_dir[PATH_MAX];
  eeprom_profile_t profile;
  const char *mcu;
  unsigned baud;
  bool realtime;
  char elf[PATH_MAX];
  const char *firmware_dir;
  bool stats;
  double bit_error_rate; /* per bit on the wire, [0, 1) */
  uint64_t noise_seed;
  usb_adapter_config_t adapter; /* between the pty and the bus (--adapter) */
  plant_options_t world;
  const char *trace_path;  /* --trace: the VCD file; NULL = no trace */
  uint8_t trace_ids[ID_LIST_MAX_ID + 1u]; /* --trace-ids: the servos traced (all of --ids if not given) */
  size_t trace_id_count;   /* 0: every servo */
  bool gdb;                /* --gdb given */
  uint8_t gdb_id;          /* the servo opened to gdb */
  unsigned gdb_port;       /* its TCP port (default EMU_GDB_DEFAULT_PORT) */
} serve_options_t;

#define EMU_GDB_DEFAULT_PORT 1234u

/* Prints the usage text, the world options included. */
void emu_print_usage(FILE *out);

/* Parses `serve [options]` (argv[0] is "serve"), checks the state directory (created if
 * needed) and the ELF. Returns -1 when the program goes on, else its exit status: 0 after
 * --help, EMU_EXIT_USAGE for bad input (one line on stderr), 1 for an unusable state
 * directory or ELF. */
int emu_parse_serve_options(int argc, char **argv, serve_options_t *o);

#endif
