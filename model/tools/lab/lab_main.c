/* SPDX-License-Identifier: GPL-3.0-or-later */
/* ax12-lab: experiments on one emulated AX-12 (the firmware ELF in simavr driving the plant),
 * observed through the protocol as a user would, for the figures of docs/control.md.
 *
 *   ax12-lab KIND [options]      KIND: step | compliance | speed-load | heating | report
 *
 * Each KIND writes CSV (a header line, then rows) to stdout; `report` writes `key,value`
 * lines. Simulated time only, as fast as the host allows. Exit status: 0, 2 for bad usage,
 * 1 for failures (missing ELF, a servo that stops answering). */
#define _GNU_SOURCE
#include <getopt.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "lab_experiments.h"
#include "plant_options.h"

#ifndef AX12_DEFAULT_FIRMWARE_DIR
#define AX12_DEFAULT_FIRMWARE_DIR "firmware"
#endif

#define EXIT_USAGE 2

static const char usage_text[] =
    "usage: ax12-lab KIND [options]\n"
    "Experiments on one emulated AX-12 (firmware ELF in simavr + plant), read through the\n"
    "protocol; CSV on stdout.\n"
    "  step         Present Position after a goal step 412 -> 612, compliance slopes\n"
    "               8, 16, 17, 32, 64, 128 (columns slope,t_ms,goal,position,speed,load)\n"
    "  compliance   goal 512, margins 1, punch 32, a load torque swept 0..+2..-2..0 N m; Present\n"
    "               Load vs error for slopes 16, 32, 64, 128\n"
    "               (slope,t_ms,load_nm,goal,position,error,present_load)\n"
    "  speed-load   wheel mode at full drive against constant loads, supplies 7, 9.6, 10, 12 V\n"
    "               (supply_v,load_nm,present_speed,protocol_rpm,plant_rpm,present_load)\n"
    "  heating      stall at full drive against a spring until the overheating alarm\n"
    "               (t_s,present_temperature,limit,case_c,winding_c,current_a,torque_enable)\n"
    "  report       key,value figures for scripts/model_report\n"
    "options:\n"
    "  --profile NAME      ax12 (default) or ax12a\n"
    "  --firmware-dir DIR  where ax12-<profile>-atmega88.elf is (default: the build's)\n"
    "  --elf PATH          another firmware ELF\n"
    "  --source-r OHM      supply source resistance (default 0: the supply at the connector;\n"
    "                      heating: 0.1 as ax12-emu serve)\n"
    "  -h, --help          this text\n"
    "World (defaults as ax12-emu serve; step/compliance/heating use --supply and --ambient):\n";

int main(int argc, char **argv) {
  lab_options_t opts = {0};
  if (argc < 2 || strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0) {
    FILE *out = argc < 2 ? stderr : stdout;
    fputs(usage_text, out);
    fputs(plant_options_help, out);
    return argc < 2 ? EXIT_USAGE : 0;
  }
  const char *kind = argv[1];
  int (*fn)(const lab_options_t *) = NULL;
  if (strcmp(kind, "step") == 0) {
    fn = lab_step;
  } else if (strcmp(kind, "compliance") == 0) {
    fn = lab_compliance;
  } else if (strcmp(kind, "speed-load") == 0) {
    fn = lab_speed_load;
  } else if (strcmp(kind, "heating") == 0) {
    fn = lab_heating;
  } else if (strcmp(kind, "report") == 0) {
    fn = lab_report;
  } else {
    fprintf(stderr, "ax12-lab: unknown KIND '%s' (see ax12-lab --help)\n", kind);
    return EXIT_USAGE;
  }
  enum { OPT_PROFILE = 256, OPT_FIRMWARE_DIR, OPT_ELF, OPT_SOURCE_R };
  static const struct option long_options[] = {
      {"profile", required_argument, NULL, OPT_PROFILE},
      {"firmware-dir", required_argument, NULL, OPT_FIRMWARE_DIR},
      {"elf", required_argument, NULL, OPT_ELF},
      {"source-r", required_argument, NULL, OPT_SOURCE_R},
      PLANT_LONG_OPTIONS,
      {"help", no_argument, NULL, 'h'},
      {NULL, 0, NULL, 0},
  };
  opts.profile = "ax12";
  plant_options_default(&opts.world);
  const char *firmware_dir = AX12_DEFAULT_FIRMWARE_DIR;
  char err[256];
  opterr = 0;
  optind = 2;
  int c;
  while ((c = getopt_long(argc, argv, ":h", long_options, NULL)) != -1) {
    switch (c) {
    case OPT_PROFILE:
      if (strcmp(optarg, "ax12") != 0 && strcmp(optarg, "ax12a") != 0) {
        fprintf(stderr, "ax12-lab: unknown profile '%s' (ax12 or ax12a)\n", optarg);
        return EXIT_USAGE;
      }
      opts.profile = optarg;
      break;
    case OPT_FIRMWARE_DIR:
      firmware_dir = optarg;
      break;
    case OPT_ELF:
      snprintf(opts.elf, sizeof(opts.elf), "%s", optarg);
      break;
    case OPT_SOURCE_R: {
      char *end = NULL;
      opts.source_r = strtod(optarg, &end);
      if (!end || *end || end == optarg || !(opts.source_r >= 0.0 && opts.source_r <= 10.0)) {
        fprintf(stderr, "ax12-lab: bad --source-r '%s': ohms, 0..10\n", optarg);
        return EXIT_USAGE;
      }
      opts.source_r_given = true;
      break;
    }
    case 'h':
      fputs(usage_text, stdout);
      fputs(plant_options_help, stdout);
      return 0;
    case ':':
      fprintf(stderr, "ax12-lab: option %s needs a value\n", argv[optind - 1]);
      return EXIT_USAGE;
    default:
      if (plant_option_name(c) != NULL) {
        if (!plant_options_parse(&opts.world, plant_option_name(c), optarg, err, sizeof(err))) {
          fprintf(stderr, "ax12-lab: %s\n", err);
          return EXIT_USAGE;
        }
        break;
      }
      fprintf(stderr, "ax12-lab: unknown option '%s'\n", argv[optind - 1]);
      return EXIT_USAGE;
    }
  }
  if (optind < argc) {
    fprintf(stderr, "ax12-lab: unexpected argument '%s'\n", argv[optind]);
    return EXIT_USAGE;
  }
  if (!opts.elf[0]) {
    snprintf(opts.elf, sizeof(opts.elf), "%s/ax12-%s-atmega88.elf", firmware_dir, opts.profile);
  }
  if (access(opts.elf, R_OK) != 0) {
    fprintf(stderr, "ax12-lab: firmware ELF %s not readable (build the firmware, or pass --elf)\n", opts.elf);
    return 1;
  }
  return fn(&opts);
}
