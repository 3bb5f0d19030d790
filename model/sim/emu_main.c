/* SPDX-License-Identifier: GPL-3.0-or-later */
/* ax12-emu: emulated AX-12 servos on a pseudo-terminal (docs/emulator.md).
 *
 *   ax12-emu serve [options]
 *
 * stdout carries exactly one line, `ready: <device>`, once a client can connect; everything
 * else goes to stderr. Exit status: 0 after SIGINT / SIGTERM / SIGHUP (state persisted),
 * 2 for bad command-line input, 1 for other failures. */
#define _GNU_SOURCE
#include <errno.h>
#include <getopt.h>
#include <limits.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "bus_noise.h"
#include "eeprom_store.h"
#include "id_list.h"
#include "pacing.h"
#include "plant_options.h"
#include "pty_bridge.h"
#include "servo.h"
#include "world.h"

#ifndef AX12_DEFAULT_FIRMWARE_DIR
#define AX12_DEFAULT_FIRMWARE_DIR "firmware"
#endif

#define EXIT_USAGE 2
#define SLICE_US 100u
#define BOOT_LIMIT_MS 2000u
#define SHUTDOWN_SETTLE_MS 500u
#define LAG_REPORT_US 20000.0
#define LAG_REPORT_PERIOD_US 10e6

static volatile sig_atomic_t stop_requested;

static void on_signal(int sig) {
  (void)sig;
  stop_requested = 1;
}

static const char usage_text[] =
    "usage: ax12-emu serve [options]\n"
    "Emulated AX-12 servos (the firmware ELF in simavr) on one bus behind a pseudo-terminal.\n"
    "Prints `ready: <device>` when a client can connect; Ctrl-C or SIGTERM stops it cleanly.\n"
    "\n"
    "  --ids LIST          servo IDs, e.g. 1 | 1,2,3 | 1-18 | 1-4,7 (default 1); each ID is\n"
    "                      its own servo with its own EEPROM (state file servo-<ID>.eeprom)\n"
    "  --link PATH         also make PATH a symlink to the device (removed on exit)\n"
    "  --state-dir DIR     where EEPROM state files live (default $XDG_STATE_HOME/ax12 or\n"
    "                      ~/.local/state/ax12); settings survive restarts\n"
    "  --profile NAME      ax12 (2006 manual, default) or ax12a\n"
    "  --mcu NAME          atmega88 (default) or atmega328p\n"
    "  --baud VALUE        Baud Rate register of servos without a state file, 0..254\n"
    "                      (default 1 = 1 Mbps; 2000000 / (VALUE + 1) bit/s)\n"
    "  --realtime          simulated time follows the wall clock (default)\n"
    "  --fast              no throttling: simulate as fast as the host allows\n"
    "  --elf PATH          firmware ELF (default: <firmware-dir>/ax12-<profile>-<mcu>.elf)\n"
    "  --firmware-dir DIR  where the firmware ELFs are (default: the build's)\n"
    "  --stats             print bus and timing statistics to stderr on exit\n"
    "  --bit-error-rate RATE\n"
    "                      noise: every bit on the wire (start, 8 data, stop) flips with\n"
    "                      probability RATE, 0 <= RATE < 1 (default 0: none), both ways;\n"
    "                      a flipped data bit changes the byte every node gets, a flipped\n"
    "                      start or stop bit is a framing error\n"
    "  --seed N            seed of the noise, 0..2^64-1 (default 1): the same seed and the\n"
    "                      same bytes on the wire give the same errors\n"
    "  -h, --help          this text\n"
    "\n"
    "The physical world of every servo (model/plant: motor, gears, pot, supply, heat):\n";

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
  plant_options_t world;
} serve_options_t;

static int fail_usage(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static int fail_usage(const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  fputs("ax12-emu: ", stderr);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fputs(" (see ax12-emu serve --help)\n", stderr);
  return EXIT_USAGE;
}

static int mkdir_p(const char *path) {
  char buf[PATH_MAX];
  if (snprintf(buf, sizeof(buf), "%s", path) >= (int)sizeof(buf)) {
    errno = ENAMETOOLONG;
    return -1;
  }
  for (char *p = buf + 1; *p; p++) {
    if (*p == '/') {
      *p = '\0';
      if (mkdir(buf, 0755) != 0 && errno != EEXIST) {
        return -1;
      }
      *p = '/';
    }
  }
  if (mkdir(buf, 0755) != 0 && errno != EEXIST) {
    return -1;
  }
  return 0;
}

/* The state directory must exist (created if needed) and accept new files. */
static bool state_dir_usable(const char *dir, char *err, size_t err_len) {
  if (mkdir_p(dir) != 0) {
    snprintf(err, err_len, "state directory %s cannot be created: %s", dir, strerror(errno));
    return false;
  }
  struct stat st;
  if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode)) {
    snprintf(err, err_len, "state directory %s is not a directory", dir);
    return false;
  }
  char probe[PATH_MAX];
  snprintf(probe, sizeof(probe), "%s/.ax12-write-test.%ld", dir, (long)getpid());
  FILE *f = fopen(probe, "w");
  if (!f) {
    snprintf(err, err_len, "state directory %s cannot be written: %s", dir, strerror(errno));
    return false;
  }
  fclose(f);
  unlink(probe);
  return true;
}

static void default_state_dir(char *out, size_t len) {
  const char *xdg = getenv("XDG_STATE_HOME");
  if (xdg && xdg[0] == '/') {
    snprintf(out, len, "%s/ax12", xdg);
    return;
  }
  const char *home = getenv("HOME");
  snprintf(out, len, "%s/.local/state/ax12", home && *home ? home : ".");
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

/* Returns -1 to go on, else an exit status. */
static int parse_serve_options(int argc, char **argv, serve_options_t *o) {
  enum { OPT_IDS = 256, OPT_LINK, OPT_STATE_DIR, OPT_PROFILE, OPT_MCU, OPT_BAUD, OPT_REALTIME, OPT_FAST, OPT_ELF,
         OPT_FIRMWARE_DIR, OPT_STATS, OPT_BIT_ERROR_RATE, OPT_SEED };
  static const struct option long_options[] = {
      {"ids", required_argument, NULL, OPT_IDS},
      {"link", required_argument, NULL, OPT_LINK},
      {"state-dir", required_argument, NULL, OPT_STATE_DIR},
      {"profile", required_argument, NULL, OPT_PROFILE},
      {"mcu", required_argument, NULL, OPT_MCU},
      {"baud", required_argument, NULL, OPT_BAUD},
      {"realtime", no_argument, NULL, OPT_REALTIME},
      {"fast", no_argument, NULL, OPT_FAST},
      {"elf", required_argument, NULL, OPT_ELF},
      {"firmware-dir", required_argument, NULL, OPT_FIRMWARE_DIR},
      {"stats", no_argument, NULL, OPT_STATS},
      {"bit-error-rate", required_argument, NULL, OPT_BIT_ERROR_RATE},
      {"seed", required_argument, NULL, OPT_SEED},
      PLANT_LONG_OPTIONS,
      {"help", no_argument, NULL, 'h'},
      {NULL, 0, NULL, 0},
  };
  char err[256];
  memset(o, 0, sizeof(*o));
  o->ids[0] = 1;
  o->id_count = 1;
  o->mcu = "atmega88";
  o->baud = 1;
  o->realtime = true;
  o->firmware_dir = AX12_DEFAULT_FIRMWARE_DIR;
  o->noise_seed = BUS_NOISE_DEFAULT_SEED;
  default_state_dir(o->state_dir, sizeof(o->state_dir));
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
      if (!parse_uint(optarg, 254, &o->baud)) {
        return fail_usage("bad --baud '%s': a Baud Rate register value 0..254", optarg);
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
    case 'h':
      fputs(usage_text, stdout);
      fputs(plant_options_help, stdout);
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
  return -1;
}

static void print_stats(const world_t *world, const pty_bridge_t *pty, const pacing_t *pacing) {
  fprintf(stderr, "ax12-emu: simulated %.3f s at %.2fx real time; ", sim_cycles_to_us(world->now) / 1e6,
          pacing_speed(pacing, world->now));
  if (pacing->realtime) {
    fprintf(stderr, "worst lag %.1f ms, %llu re-alignments; ", pacing->max_behind_us / 1e3,
            (unsigned long long)pacing->realignments);
  }
  fprintf(stderr, "client bytes in %llu, out %llu (dropped %llu); bus collisions %llu, baud mismatches %llu\n",
          (unsigned long long)pty->from_client, (unsigned long long)pty->to_client,
          (unsigned long long)pty->dropped_to_client, (unsigned long long)world->bus.collided_bytes,
          (unsigned long long)world->bus.mismatched_deliveries);
  if (world->bus.noise.bit_error_rate > 0.0) {
    fprintf(stderr, "ax12-emu: noise at %g per bit: %llu bytes corrupted, %llu bits flipped\n",
            world->bus.noise.bit_error_rate, (unsigned long long)world->bus.noise_corrupted_bytes,
            (unsigned long long)world->bus.noise_flipped_bits);
  }
  for (size_t i = 0; i < world->servo_count; i++) {
    const servo_t *s = world->servos[i];
    const uart_link_t *l = &s->board.link;
    fprintf(stderr,
            "ax12-emu: %s: rx %llu (overrun %llu, late %llu), tx %llu (undriven %llu), EEPROM writes %llu, "
            "persisted %llu%s\n",
            s->name, (unsigned long long)l->rx_bytes, (unsigned long long)l->rx_overruns,
            (unsigned long long)l->rx_late, (unsigned long long)l->tx_bytes, (unsigned long long)l->tx_undriven,
            (unsigned long long)s->eeprom_writes, (unsigned long long)s->persists, s->halted ? ", HALTED" : "");
  }
}

static sim_cycles_t sim_of_wall(void *ctx, double wall_us) { return pacing_sim_at(ctx, wall_us); }

static int serve(int argc, char **argv) {
  serve_options_t o;
  const int parsed = parse_serve_options(argc, argv, &o);
  if (parsed >= 0) {
    return parsed;
  }
  char err[512];
  world_t *world = world_create(o.elf, o.mcu, o.profile, err, sizeof(err));
  if (!world) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    return 1;
  }
  (void)bus_set_noise(&world->bus, o.bit_error_rate, o.noise_seed); /* validated by the parser */
  for (size_t i = 0; i < o.id_count; i++) {
    char path[PATH_MAX + 32];
    eeprom_store_path(path, sizeof(path), o.state_dir, o.ids[i]);
    if (!world_add_servo(world, o.ids[i], (uint8_t)o.baud, path, err, sizeof(err))) {
      fprintf(stderr, "ax12-emu: servo %u: %s\n", o.ids[i], err);
      world_destroy(world);
      return 1;
    }
  }
  ax12_plant_t plant;
  plant_options_build(&o.world, &plant);
  for (size_t i = 0; i < world->servo_count; i++) {
    servo_attach_plant(world->servos[i], &plant);
  }
  /* The pty starts at the first servo's baud, so a client that sets none still talks. */
  uint8_t first_baud = (uint8_t)o.baud;
  (void)eeprom_store_image_fields(world->servos[0]->eeprom, world->servos[0]->eeprom_size, NULL, &first_baud);
  pty_bridge_t pty;
  if (pty_bridge_open(&pty, world, sim_baud_reg_to_bps(first_baud), o.link, err, sizeof(err)) != 0) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    world_destroy(world);
    return 1;
  }

  struct sigaction sa;
  memset(&sa, 0, sizeof(sa));
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, NULL);
  sigaction(SIGTERM, &sa, NULL);
  sigaction(SIGHUP, &sa, NULL);
  signal(SIGPIPE, SIG_IGN);

  pacing_t pacing;
  pacing_start(&pacing, o.realtime, world->now);
  const sim_cycles_t slice = sim_us(SLICE_US);

  /* Boot: until every servo listens on the bus. */
  bool booted = false;
  while (!stop_requested && world->now < sim_ms(BOOT_LIMIT_MS)) {
    booted = true;
    for (size_t i = 0; i < world->servo_count; i++) {
      booted &= servo_listening(world->servos[i]);
    }
    if (booted) {
      break;
    }
    world_run_until(world, world->now + slice);
    (void)pacing_wait(&pacing, world->now, -1);
  }
  if (!booted && !stop_requested) {
    fprintf(stderr, "ax12-emu: warning: not every servo enabled its UART within %u ms\n", BOOT_LIMIT_MS);
  }
  printf("ready: %s\n", pty.device);
  fflush(stdout);
  fprintf(stderr, "ax12-emu: %zu servo%s (%s, %s) on %s%s%s, state in %s, %s\n", world->servo_count,
          world->servo_count == 1 ? "" : "s", eeprom_profile_name(o.profile), o.mcu, pty.device, o.link ? " = " : "",
          o.link ? o.link : "", o.state_dir, o.realtime ? "real time" : "fast");

  bool warned_persist = false;
  double lag_report_at_us = pacing_wall_us() + LAG_REPORT_PERIOD_US;
  double lag_reported_us = 0.0;
  while (!stop_requested) {
    /* Up to the next client byte's arrival at most (it enters the wire at that exact time). */
    sim_cycles_t until = world->now + slice;
    const sim_cycles_t next_input = pty_bridge_next_input(&pty);
    if (next_input > world->now && next_input < until) {
      until = next_input;
    }
    world_run_until(world, until);
    (void)pty_bridge_pump(&pty, o.realtime ? sim_of_wall : NULL, &pacing);
    if (!warned_persist) {
      for (size_t i = 0; i < world->servo_count; i++) {
        if (world->servos[i]->persist_errors) {
          fprintf(stderr, "ax12-emu: %s: %s\n", world->servos[i]->name, world->servos[i]->last_error);
          warned_persist = true;
        }
      }
    }
    world_park(world);
    if (pacing_wait(&pacing, world->now, pty_bridge_wake_fd(&pty))) {
      (void)pty_bridge_pump(&pty, o.realtime ? sim_of_wall : NULL, &pacing);
    }
    if (o.realtime && pacing_wall_us() >= lag_report_at_us) {
      /* At most one line per period, only when the lag grew past the threshold. */
      const double lag = pacing.max_behind_us;
      if (lag > LAG_REPORT_US && lag > lag_reported_us) {
        fprintf(stderr, "ax12-emu: warning: the simulation ran up to %.0f ms behind real time (%.2fx overall)\n",
                lag / 1e3, pacing_speed(&pacing, world->now));
        lag_reported_us = lag;
      }
      lag_report_at_us = pacing_wall_us() + LAG_REPORT_PERIOD_US;
    }
  }

  const int failures = world_settle_and_persist(world, sim_ms(SHUTDOWN_SETTLE_MS));
  if (failures) {
    for (size_t i = 0; i < world->servo_count; i++) {
      if (world->servos[i]->persist_errors) {
        fprintf(stderr, "ax12-emu: %s: %s\n", world->servos[i]->name, world->servos[i]->last_error);
      }
    }
  }
  if (o.stats) {
    print_stats(world, &pty, &pacing);
  }
  pty_bridge_close(&pty);
  world_destroy(world);
  return failures ? 1 : 0;
}

int main(int argc, char **argv) {
  if (argc < 2) {
    fputs(usage_text, stderr);
    fputs(plant_options_help, stderr);
    return EXIT_USAGE;
  }
  if (strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "help") == 0) {
    fputs(usage_text, stdout);
    fputs(plant_options_help, stdout);
    return 0;
  }
  if (strcmp(argv[1], "serve") == 0) {
    return serve(argc - 1, argv + 1);
  }
  fprintf(stderr, "ax12-emu: unknown command '%s' (see ax12-emu --help)\n", argv[1]);
  return EXIT_USAGE;
}
