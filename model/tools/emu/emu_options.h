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
#include "emu_bus_play.h"
#include "id_list.h"
#include "plant_options.h"
#include "robot_model.h"
#include "usb_adapter.h"

/* --world ID:OPTION=VALUE entries at most. */
#define EMU_SERVO_WORLD_MAX 64u

/* One servo's own world option (--world ID:OPTION=VALUE), applied over the bus-wide ones. */
typedef struct {
  uint8_t id;
  char option[16]; /* a world option's name without dashes, e.g. "load-torque" */
  char value[64];
} servo_world_option_t;

/* Exit status for bad command-line input. */
#define EMU_EXIT_USAGE 2

typedef struct {
  uint8_t ids[ID_LIST_MAX_ID + 1u];
  size_t id_count;
  bool ids_given;                /* --ids given (else only the robot's servos, or servo 1) */
  const char *robot_spec;        /* --robot NAME|FILE.xml, NULL: none */
  robot_model_t *robot;          /* loaded and checked by the parser; its servos are in ids */
  const char *log_joints;        /* --log-joints FILE.csv, NULL: none */
  const char *play_bus;          /* --play-bus FILE.csv, NULL: none */
  emu_bus_play_t play;           /* its rows, read by the parser */
  const char *link;
  char state_dir[PATH_MAX];
  eeprom_profile_t profile;
  const char *mcu;
  unsigned baud_register;        /* Baud Rate of servos without a state file (--baud, --baud-register) */
  bool realtime;
  char elf[PATH_MAX];
  char bootloader[PATH_MAX];    /* the bootloader ELF beside the application; "" = none */
  bool bootloader_given;        /* --bootloader PATH or none */
  const char *firmware_dir;
  bool stats;
  double bit_error_rate; /* per bit on the wire, [0, 1) */
  uint64_t noise_seed;
  usb_adapter_config_t adapter; /* between the pty and the bus (--adapter) */
  const char *log_bus;          /* --log-bus FILE.csv, NULL for none (no bus tap at all) */
  plant_options_t world;         /* every servo's world (--supply, --load-torque, ...) */
  servo_world_option_t servo_world[EMU_SERVO_WORLD_MAX];
  size_t servo_world_count;
  char control_path[PATH_MAX];   /* the control socket (emu_control.h) */
  bool control_explicit;         /* given with --control: failing to open it is an error */
  const char *dashboard;         /* --dashboard [HOST:]PORT, NULL: none (emu_dashboard.h) */
  const char *trace_path;  /* --trace: the VCD file; NULL = no trace */
  uint8_t trace_ids[ID_LIST_MAX_ID + 1u]; /* --trace-ids: the servos traced (all of --ids if not given) */
  size_t trace_id_count;   /* 0: every servo */
  bool gdb;                /* --gdb given */
  uint8_t gdb_id;          /* the servo opened to gdb */
  unsigned gdb_port;       /* its TCP port (default EMU_GDB_DEFAULT_PORT) */
} serve_options_t;

#define EMU_GDB_DEFAULT_PORT 1234u

/* Where the robots shipped with the project are (--robot NAME). */
#ifndef AX12_ROBOTS_DIR
#define AX12_ROBOTS_DIR "model/robots"
#endif

/* Servo `id`'s world: the bus-wide options with its own --world entries over them (a load of
 * its own replaces the bus-wide one). False with err set when they conflict (the parser
 * checks every servo's, so after it this is always true). */
bool emu_servo_world(const serve_options_t *o, uint8_t id, plant_options_t *world, char *err, size_t err_len);

/* Prints the usage text, the world options included. */
void emu_print_usage(FILE *out);

/* Parses `serve [options]` (argv[0] is "serve"), loads and checks --robot's model (its servos
 * join --ids), checks the state directory (created if
 * needed), the ELF and the bootloader ELF (default: <firmware-dir>/ax12-boot-<mcu>.elf on the
 * ATmega328P when that file exists, none on the ATmega88). Returns -1 when the program goes on, else its exit status: 0 after
 * --help, EMU_EXIT_USAGE for bad input (one line on stderr), 1 for an unusable state
 * directory or ELF. */
int emu_parse_serve_options(int argc, char **argv, serve_options_t *o);

#endif
