/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include "emu_options.h"

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bus.h"
#include "bus_noise.h"
#include "elf_check.h"
#include "emu_firmware_choice.h"
#include "state_dir.h"

#ifndef AX12_DEFAULT_FIRMWARE_DIR
#define AX12_DEFAULT_FIRMWARE_DIR "firmware"
#endif

static const char usage_text[] =
    "usage: ax12-emu serve [options]\n"
    "Emulated AX-12 servos (the firmware ELF in simavr) on one bus behind a pseudo-terminal.\n"
    "Prints `ready: <device>` when a client can connect; Ctrl-C or SIGTERM stops it cleanly.\n"
    "\n"
    "  --ids LIST          servo IDs, e.g. 1 | 1,2,3 | 1-18 | 1-4,7 (default 1); each ID is\n"
    "                      its own servo with its own EEPROM (state file servo-<ID>.eeprom)\n"
    "  --link PATH         also make PATH a symlink to the device (removed on exit)\n"
    "  --state-dir DIR     where the state files live (default $XDG_STATE_HOME/ax12 or\n"
    "                      ~/.local/state/ax12): servo-<ID>.eeprom, and servo-<ID>.flash\n"
    "                      once a bootloader changed the flash; both survive restarts\n"
    "  --profile NAME      ax12 (2006 manual, default) or ax12a\n"
    "  --mcu NAME          atmega88 (default) or atmega328p\n"
    "  --baud BPS          bit/s of servos without a state file, as a client sets it\n"
    "                      (default 1000000): an AX-12 rate, 2000000 / (N + 1) for N\n"
    "                      0..254, or within 3 % of one (57600, 115200, 9600...)\n"
    "  --baud-register N   the same as the Baud Rate register's value N, 0..254\n"
    "  --realtime          simulated time follows the wall clock (default)\n"
    "  --fast              no throttling: simulate as fast as the host allows\n"
    "  --elf PATH          firmware ELF (default: <firmware-dir>/ax12-<profile>-<mcu>.elf)\n"
    "  --firmware-dir DIR  where the firmware ELFs are (default: the build's)\n"
    "  --bootloader PATH|none\n"
    "                      the bootloader ELF in the flash beside the application, where\n"
    "                      every reset starts (BOOTRST), with the application's record\n"
    "                      (docs/bootloader.md); its updates over the bus are kept in\n"
    "                      servo-<ID>.flash (default: <firmware-dir>/ax12-boot-<mcu>.elf\n"
    "                      when it exists, --elf is this project's application and ends\n"
    "                      below the application record; else none)\n"
    "  --adapter KIND[:MS] the USB serial adapter between the client and the bus:\n"
    "                      u2d2 (default; FT232H class, high speed), usb2dynamixel (FT232R,\n"
    "                      full speed) or wire (no adapter: each byte as it leaves the wire).\n"
    "                      MS is the chip's latency timer, 1..255 (default 1, as ROBOTIS\n"
    "                      advises; Linux's default is 16): bytes from the bus reach the\n"
    "                      client when a USB packet fills or the timer expires; a write\n"
    "                      reaches the wire at the next USB frame; the bus sees the baud\n"
    "                      the chip makes of the client's (docs/emulator.md)\n"
    "  --robot NAME|FILE.xml\n"
    "                      a robot of AX-12s (docs/robot.md): a MuJoCo model whose joints\n"
    "                      bound to servo IDs (<numeric name=\"ax12:JOINT\" data=\"ID\"/>)\n"
    "                      are those servos' output shafts, its physics stepped in lock with\n"
    "                      the firmwares; shipped: pendulum, arm, hexapod. Its servos join\n"
    "                      --ids (without --ids: only they); servos not in it keep the loads\n"
    "  --log-joints FILE   with --robot: every physics step's simulated time and qpos, one\n"
    "                      CSV row each (exact: 17 significant digits)\n"
    "  --play-bus FILE     put the client's packets of a --log-bus CSV on the bus at their\n"
    "                      recorded simulated times (a scripted master beside the pty)\n"
    "  --world ID:OPTION=VALUE\n"
    "                      servo ID's own world, over the bus-wide options below (repeat\n"
    "                      for more), e.g. --world 3:load-torque=1.2 --world 3:supply=7\n"
    "  --control PATH      the control socket for the dashboard and `ax12 world`\n"
    "                      (default <state-dir>/control.sock; docs/dashboard.md)\n"
    "  --dashboard [HOST:]PORT\n"
    "                      also serve the live dashboard at http://HOST:PORT/ (HOST\n"
    "                      default 127.0.0.1: this machine only; docs/dashboard.md)\n"
    "  --stats             print bus, adapter and timing statistics to stderr on exit\n"
    "  --log-bus FILE      every packet on the bus, one CSV row each (time, sender, ID,\n"
    "                      instruction or error bits, parameters, checksum, collision, raw\n"
    "                      bytes); replay it with `scripts/ax12 replay` (docs/emulator.md)\n"
    "  --bit-error-rate RATE\n"
    "                      noise: every bit on the wire (start, 8 data, stop) flips with\n"
    "                      probability RATE, 0 <= RATE < 1 (default 0: none), both ways;\n"
    "                      a flipped data bit changes the byte every node gets, a flipped\n"
    "                      start or stop bit is a framing error\n"
    "  --seed N            seed of the noise, 0..2^64-1 (default 1): the same seed and the\n"
    "                      same bytes on the wire give the same errors\n"
    "  --trace FILE.vcd    write every servo's pins (bus RX / TX and direction, H-bridge PWM,\n"
    "                      LED, duty registers, the control tick's interrupt) as a VCD\n"
    "                      waveform in simulated time, for GTKWave (docs/debugging.md);\n"
    "                      about 2 MB per simulated second per servo driving its motor\n"
    "  --trace-ids LIST    trace only these servos (a subset of --ids; default: all)\n"
    "  --gdb ID[:PORT]     open servo ID's firmware to avr-gdb on TCP PORT (default 1234):\n"
    "                      `target remote :PORT`; it runs until gdb attaches; while gdb\n"
    "                      holds it stopped, the whole bus stops (docs/debugging.md)\n"
    "  -h, --help          this text\n"
    "\n"
    "The physical world of every servo (model/plant: motor, gears, pot, supply, heat):\n";

void emu_print_usage(FILE *out) {
  fputs(usage_text, out);
  fputs(plant_options_help, out);
}

static int fail_usage(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static int fail_usage(const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  fputs("ax12-emu: ", stderr);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fputs(" (see scripts/ax12 serve --help)\n", stderr);
  return EMU_EXIT_USAGE;
}

static bool parse_uint(const char *text, unsigned max, unsigned *value) {
  char *end = NULL;
  errno = 0;
  const unsigned long v = strtoul(text, &end, 10);
  if (errno || !end || *end || end == text || text[0] == '-' || v > max) {
    return false;
  }
  *value = (unsigned)v;
  return true;
}

/* The Baud Rate register value whose rate, 2000000 / (N + 1) bit/s, is nearest to bps, when
 * within the tolerance a receiver takes (BUS_BAUD_TOLERANCE): a client at bps talks to it. */
static bool baud_register_of_bps(const char *text, unsigned *reg) {
  unsigned bps = 0;
  if (!parse_uint(text, 100000000u, &bps) || bps == 0) {
    return false;
  }
  unsigned best = 0;
  for (unsigned n = 1; n <= 254u; n++) {
    if (fabs(sim_baud_reg_to_bps(n) - bps) < fabs(sim_baud_reg_to_bps(best) - bps)) {
      best = n;
    }
  }
  if (fabs(sim_baud_reg_to_bps(best) - bps) > BUS_BAUD_TOLERANCE * bps) {
    return false;
  }
  *reg = best;
  return true;
}

/* A whole decimal number in 0..UINT64_MAX. */
static bool parse_u64(const char *text, uint64_t *value) {
  char *end = NULL;
  errno = 0;
  const unsigned long long v = strtoull(text, &end, 10);
  if (text[0] < '0' || text[0] > '9' || errno || !end || *end) { /* no sign, no blanks */
    return false;
  }
  *value = (uint64_t)v;
  return true;
}

/* A decimal number (strtod syntax: 1e-4 too) that is a valid bit error rate (bus_noise_rate_valid). */
static bool parse_bit_error_rate(const char *text, double *rate) {
  char *end = NULL;
  errno = 0;
  const double v = strtod(text, &end);
  if (errno || !end || *end || end == text || !isfinite(v) || !bus_noise_rate_valid(v)) {
    return false;
  }
  *rate = v;
  return true;
}

/* "PORT" or "HOST:PORT" with PORT 1..65535 (the host is checked when the dashboard binds). */
static bool listen_address_valid(const char *text) {
  const char *colon = strrchr(text, ':');
  const char *port = colon ? colon + 1 : text;
  unsigned value = 0;
  return (colon == NULL || colon > text) && parse_uint(port, 65535, &value) && value > 0;
}

/* "ID:OPTION=VALUE", the option a world option (plant_options.h) whose value it accepts. */
static bool parse_servo_world(const char *text, servo_world_option_t *out, char *err, size_t err_len) {
  const char *colon = strchr(text, ':');
  const char *equals = colon ? strchr(colon, '=') : NULL;
  unsigned id = 0;
  char id_text[8];
  if (!colon || !equals || (size_t)(colon - text) >= sizeof(id_text)) {
    snprintf(err, err_len, "'%s': ID:OPTION=VALUE, e.g. 3:load-torque=1.2", text);
    return false;
  }
  snprintf(id_text, sizeof(id_text), "%.*s", (int)(colon - text), text);
  if (!parse_uint(id_text, ID_LIST_MAX_ID, &id)) {
    snprintf(err, err_len, "'%s': the ID must be 0..%u", text, ID_LIST_MAX_ID);
    return false;
  }
  const size_t name_len = (size_t)(equals - colon - 1);
  if (name_len == 0 || name_len >= sizeof(out->option) || strlen(equals + 1) >= sizeof(out->value)) {
    snprintf(err, err_len, "'%s': unknown world option", text);
    return false;
  }
  out->id = (uint8_t)id;
  snprintf(out->option, sizeof(out->option), "%.*s", (int)name_len, colon + 1);
  snprintf(out->value, sizeof(out->value), "%s", equals + 1);
  plant_options_t scratch;
  plant_options_default(&scratch);
  return plant_options_parse(&scratch, out->option, out->value, err, err_len);
}

bool emu_servo_world(const serve_options_t *o, uint8_t id, plant_options_t *world, char *err, size_t err_len) {
  *world = o->world;
  for (size_t i = 0; i < o->servo_world_count; i++) {
    const servo_world_option_t *w = &o->servo_world[i];
    if (w->id != id) {
      continue;
    }
    if (strncmp(w->option, "load-", 5) == 0 && world->load_option && strcmp(world->load_option, w->option) != 0 &&
        world->load_option == o->world.load_option) {
      world->load_option = NULL; /* the servo's own load replaces the bus-wide one */
    }
    if (!plant_options_parse(world, w->option, w->value, err, err_len)) {
      return false;
    }
  }
  return true;
}

/* --gdb ID[:PORT]. */
static bool parse_gdb(const char *text, serve_options_t *o) {
  char id_text[16];
  const char *colon = strchr(text, ':');
  const size_t id_len = colon ? (size_t)(colon - text) : strlen(text);
  unsigned id = 0, port = EMU_GDB_DEFAULT_PORT;
  if (id_len == 0 || id_len >= sizeof(id_text)) {
    return false;
  }
  memcpy(id_text, text, id_len);
  id_text[id_len] = '\0';
  if (!parse_uint(id_text, ID_LIST_MAX_ID, &id) || (colon && (!parse_uint(colon + 1, 65535, &port) || port == 0))) {
    return false;
  }
  o->gdb = true;
  o->gdb_id = (uint8_t)id;
  o->gdb_port = port;
  return true;
}

static bool id_listed(const serve_options_t *o, uint8_t id) {
  for (size_t i = 0; i < o->id_count; i++) {
    if (o->ids[i] == id) {
      return true;
    }
  }
  return false;
}

/* --robot: the model loaded and checked, its servos joined to --ids (only they without
 * --ids), no --world load or angle on a servo of it. -1 when it goes on, else the exit status
 * (one line on stderr). */
static int load_robot(serve_options_t *o) {
  char err[1024];
  o->robot = calloc(1, sizeof(*o->robot));
  if (!o->robot) {
    fprintf(stderr, "ax12-emu: --robot: out of memory\n");
    return 1;
  }
  if (!robot_model_load(o->robot, o->robot_spec, AX12_ROBOTS_DIR, err, sizeof err)) {
    fprintf(stderr, "ax12-emu: --robot %s: %s\n", o->robot_spec, err);
    free(o->robot);
    o->robot = NULL;
    return EMU_EXIT_USAGE;
  }
  if (!o->ids_given) {
    o->id_count = 0;
  }
  for (size_t i = 0; i < o->robot->binding_count; i++) {
    if (!id_listed(o, o->robot->bindings[i].id)) {
      o->ids[o->id_count++] = o->robot->bindings[i].id;
    }
  }
  for (size_t i = 0; i < o->servo_world_count; i++) {
    const servo_world_option_t *w = &o->servo_world[i];
    const robot_binding_t *b = robot_model_binding(o->robot, w->id);
    if (b && (strncmp(w->option, "load-", 5) == 0 || strcmp(w->option, "angle") == 0)) {
      fprintf(stderr, "ax12-emu: --world %u:%s: servo %u is joint '%s' of the robot: its load and its angle are the "
                      "robot's\n", w->id, w->option, w->id, b->name);
      return EMU_EXIT_USAGE;
    }
  }
  if (o->robot->note[0]) {
    fprintf(stderr, "ax12-emu: --robot %s: %s\n", o->robot_spec, o->robot->note);
  }
  return -1;
}

int emu_parse_serve_options(int argc, char **argv, serve_options_t *o) {
  enum { OPT_IDS = 256, OPT_LINK, OPT_STATE_DIR, OPT_PROFILE, OPT_MCU, OPT_BAUD, OPT_BAUD_REGISTER, OPT_REALTIME, OPT_FAST, OPT_ELF,
         OPT_FIRMWARE_DIR, OPT_STATS, OPT_BIT_ERROR_RATE, OPT_SEED, OPT_ADAPTER,
         OPT_WORLD, OPT_CONTROL, OPT_DASHBOARD, OPT_LOG_BUS,
         OPT_TRACE, OPT_TRACE_IDS, OPT_GDB, OPT_BOOTLOADER, OPT_ROBOT, OPT_LOG_JOINTS, OPT_PLAY_BUS };
  static const struct option long_options[] = {
      {"ids", required_argument, NULL, OPT_IDS},
      {"link", required_argument, NULL, OPT_LINK},
      {"state-dir", required_argument, NULL, OPT_STATE_DIR},
      {"profile", required_argument, NULL, OPT_PROFILE},
      {"mcu", required_argument, NULL, OPT_MCU},
      {"baud", required_argument, NULL, OPT_BAUD},
      {"baud-register", required_argument, NULL, OPT_BAUD_REGISTER},
      {"realtime", no_argument, NULL, OPT_REALTIME},
      {"fast", no_argument, NULL, OPT_FAST},
      {"elf", required_argument, NULL, OPT_ELF},
      {"firmware-dir", required_argument, NULL, OPT_FIRMWARE_DIR},
      {"bootloader", required_argument, NULL, OPT_BOOTLOADER},
      {"stats", no_argument, NULL, OPT_STATS},
      {"bit-error-rate", required_argument, NULL, OPT_BIT_ERROR_RATE},
      {"seed", required_argument, NULL, OPT_SEED},
      {"adapter", required_argument, NULL, OPT_ADAPTER},
      {"world", required_argument, NULL, OPT_WORLD},
      {"control", required_argument, NULL, OPT_CONTROL},
      {"dashboard", required_argument, NULL, OPT_DASHBOARD},
      {"log-bus", required_argument, NULL, OPT_LOG_BUS},
      {"trace", required_argument, NULL, OPT_TRACE},
      {"trace-ids", required_argument, NULL, OPT_TRACE_IDS},
      {"gdb", required_argument, NULL, OPT_GDB},
      {"robot", required_argument, NULL, OPT_ROBOT},
      {"log-joints", required_argument, NULL, OPT_LOG_JOINTS},
      {"play-bus", required_argument, NULL, OPT_PLAY_BUS},
      PLANT_LONG_OPTIONS,
      {"help", no_argument, NULL, 'h'},
      {NULL, 0, NULL, 0},
  };
  char err[256];
  memset(o, 0, sizeof(*o));
  o->ids[0] = 1;
  o->id_count = 1;
  o->mcu = "atmega88";
  o->baud_register = 1;
  const char *baud_given = NULL; /* --baud or --baud-register, as given: one of the two */
  o->realtime = true;
  o->firmware_dir = AX12_DEFAULT_FIRMWARE_DIR;
  o->noise_seed = BUS_NOISE_DEFAULT_SEED;
  o->adapter = (usb_adapter_config_t){.kind = USB_ADAPTER_DEFAULT_KIND, .latency_ms = USB_ADAPTER_DEFAULT_LATENCY_MS};
  state_dir_default(o->state_dir, sizeof(o->state_dir));
  plant_options_default(&o->world);
  opterr = 0;
  optind = 1;
  int c;
  while ((c = getopt_long(argc, argv, ":h", long_options, NULL)) != -1) {
    switch (c) {
    case OPT_IDS:
      if (!id_list_parse(optarg, o->ids, &o->id_count, err, sizeof(err))) {
        return fail_usage("--ids: %s", err);
      }
      o->ids_given = true;
      break;
    case OPT_ROBOT:
      o->robot_spec = optarg;
      break;
    case OPT_LOG_JOINTS:
      if (!optarg[0]) {
        return fail_usage("empty --log-joints");
      }
      o->log_joints = optarg;
      break;
    case OPT_PLAY_BUS:
      if (!optarg[0]) {
        return fail_usage("empty --play-bus");
      }
      o->play_bus = optarg;
      break;
    case OPT_LINK:
      o->link = optarg;
      break;
    case OPT_STATE_DIR:
      if (!optarg[0]) {
        return fail_usage("empty --state-dir");
      }
      snprintf(o->state_dir, sizeof(o->state_dir), "%s", optarg);
      break;
    case OPT_PROFILE:
      if (!eeprom_profile_parse(optarg, &o->profile)) {
        return fail_usage("unknown profile '%s' (ax12 or ax12a)", optarg);
      }
      break;
    case OPT_MCU:
      if (strcmp(optarg, "atmega88") != 0 && strcmp(optarg, "atmega328p") != 0) {
        return fail_usage("unknown MCU '%s' (atmega88 or atmega328p)", optarg);
      }
      o->mcu = optarg;
      break;
    case OPT_BAUD:
    case OPT_BAUD_REGISTER:
      if (baud_given) {
        return fail_usage("%s and %s: give the servos' rate once", baud_given,
                          c == OPT_BAUD ? "--baud" : "--baud-register");
      }
      baud_given = c == OPT_BAUD ? "--baud" : "--baud-register";
      if (c == OPT_BAUD && !baud_register_of_bps(optarg, &o->baud_register)) {
        return fail_usage("bad --baud '%s': bit/s an AX-12 runs at, 2000000 / (N + 1) for N 0..254 or within 3 %% "
                          "of one (e.g. 1000000, 57600; --baud-register N gives N itself)", optarg);
      }
      if (c == OPT_BAUD_REGISTER && !parse_uint(optarg, 254, &o->baud_register)) {
        return fail_usage("bad --baud-register '%s': a Baud Rate register value 0..254", optarg);
      }
      break;
    case OPT_REALTIME:
      o->realtime = true;
      break;
    case OPT_FAST:
      o->realtime = false;
      break;
    case OPT_ELF:
      snprintf(o->elf, sizeof(o->elf), "%s", optarg);
      break;
    case OPT_FIRMWARE_DIR:
      o->firmware_dir = optarg;
      break;
    case OPT_BOOTLOADER:
      if (!optarg[0]) {
        return fail_usage("empty --bootloader (a path, or none)");
      }
      snprintf(o->bootloader, sizeof(o->bootloader), "%s", strcmp(optarg, "none") == 0 ? "" : optarg);
      o->bootloader_given = true;
      break;
    case OPT_STATS:
      o->stats = true;
      break;
    case OPT_BIT_ERROR_RATE:
      if (!parse_bit_error_rate(optarg, &o->bit_error_rate)) {
        return fail_usage("bad --bit-error-rate '%s': a probability per bit, 0 <= RATE < 1", optarg);
      }
      break;
    case OPT_SEED:
      if (!parse_u64(optarg, &o->noise_seed)) {
        return fail_usage("bad --seed '%s': a whole number 0..18446744073709551615", optarg);
      }
      break;
    case OPT_ADAPTER:
      if (!usb_adapter_parse(optarg, &o->adapter, err, sizeof(err))) {
        return fail_usage("--adapter: %s", err);
      }
      break;
    case OPT_WORLD:
      if (o->servo_world_count == EMU_SERVO_WORLD_MAX) {
        return fail_usage("more than %u --world options", EMU_SERVO_WORLD_MAX);
      }
      if (!parse_servo_world(optarg, &o->servo_world[o->servo_world_count], err, sizeof(err))) {
        return fail_usage("--world: %s", err);
      }
      o->servo_world_count++;
      break;
    case OPT_CONTROL:
      if (!optarg[0]) {
        return fail_usage("empty --control");
      }
      snprintf(o->control_path, sizeof(o->control_path), "%s", optarg);
      o->control_explicit = true;
      break;
    case OPT_DASHBOARD:
      if (!listen_address_valid(optarg)) {
        return fail_usage("bad --dashboard '%s': [HOST:]PORT, PORT 1..65535", optarg);
      }
      o->dashboard = optarg;
      break;
    case OPT_LOG_BUS:
      if (!optarg[0]) {
        return fail_usage("empty --log-bus");
      }
      o->log_bus = optarg;
      break;
    case OPT_TRACE:
      if (!optarg[0]) {
        return fail_usage("empty --trace");
      }
      o->trace_path = optarg;
      break;
    case OPT_TRACE_IDS:
      if (!id_list_parse(optarg, o->trace_ids, &o->trace_id_count, err, sizeof(err))) {
        return fail_usage("--trace-ids: %s", err);
      }
      break;
    case OPT_GDB:
      if (!parse_gdb(optarg, o)) {
        return fail_usage("bad --gdb '%s': ID[:PORT], ID 0..253, PORT 1..65535", optarg);
      }
      break;
    case 'h':
      emu_print_usage(stdout);
      return 0;
    case ':':
      return fail_usage("option %s needs a value", argv[optind - 1]);
    default:
      if (plant_option_name(c) != NULL) {
        if (!plant_options_parse(&o->world, plant_option_name(c), optarg, err, sizeof(err))) {
          return fail_usage("%s", err);
        }
        break;
      }
      return fail_usage("unknown option '%s'", argv[optind - 1]);
    }
  }
  if (optind < argc) {
    return fail_usage("unexpected argument '%s'", argv[optind]);
  }
  if (o->log_joints && !o->robot_spec) {
    return fail_usage("--log-joints without --robot");
  }
  if (o->robot_spec) {
    const int status = load_robot(o);
    if (status >= 0) {
      return status;
    }
  }
  if (o->play_bus && emu_bus_play_load(&o->play, o->play_bus, err, sizeof(err)) != 0) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    return EMU_EXIT_USAGE;
  }
  if (o->trace_id_count && !o->trace_path) {
    return fail_usage("--trace-ids without --trace");
  }
  for (size_t i = 0; i < o->trace_id_count; i++) {
    if (!id_listed(o, o->trace_ids[i])) {
      return fail_usage("--trace-ids: servo %u is not on the bus (--ids)", o->trace_ids[i]);
    }
  }
  if (o->gdb && !id_listed(o, o->gdb_id)) {
    return fail_usage("--gdb: servo %u is not on the bus (--ids)", o->gdb_id);
  }
  for (size_t i = 0; i < o->servo_world_count; i++) {
    if (!id_listed(o, o->servo_world[i].id)) {
      return fail_usage("--world %u:%s: no servo %u in --ids", o->servo_world[i].id, o->servo_world[i].option,
                        o->servo_world[i].id);
    }
    plant_options_t world;
    if (!emu_servo_world(o, o->servo_world[i].id, &world, err, sizeof(err))) {
      return fail_usage("--world, servo %u: %s", o->servo_world[i].id, err);
    }
  }
  if (!o->control_path[0]) {
    const int n = snprintf(o->control_path, sizeof(o->control_path), "%s/control.sock", o->state_dir);
    if (n < 0 || (size_t)n >= sizeof(o->control_path)) {
      o->control_path[0] = '\0';
    }
  }
  if (!o->elf[0]) {
    snprintf(o->elf, sizeof(o->elf), "%s/ax12-%s-%s.elf", o->firmware_dir, eeprom_profile_name(o->profile), o->mcu);
  }
  if (!state_dir_usable(o->state_dir, err, sizeof(err))) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    return 1;
  }
  if (access(o->elf, R_OK) != 0) {
    fprintf(stderr, "ax12-emu: firmware ELF %s: %s (build the firmware, or pass --elf)\n", o->elf, strerror(errno));
    return 1;
  }
  if (!elf_check_avr(o->elf, o->mcu, err, sizeof(err))) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    return 1;
  }
  emu_firmware_choose_bootloader(o);
  if (o->bootloader[0] && access(o->bootloader, R_OK) != 0) {
    fprintf(stderr, "ax12-emu: bootloader ELF %s: %s (build the firmware, or pass --bootloader none)\n",
            o->bootloader, strerror(errno));
    return 1;
  }
  if (o->bootloader[0] && !elf_check_avr(o->bootloader, o->mcu, err, sizeof(err))) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    return 1;
  }
  return -1;
}

