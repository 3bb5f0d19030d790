/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The physical world of `ax12-emu serve` and `ax12-lab`: supply, air temperature, the load on
 * the output and its starting angle, parsed from command-line values into an ax12_plant_t
 * (model/plant). */
#ifndef SIM_PLANT_OPTIONS_H
#define SIM_PLANT_OPTIONS_H

#include <stdbool.h>
#include <stddef.h>

#include "plant.h"

typedef struct {
  double supply_v;   /* --supply VOLTS (default 9.6) */
  double ambient_c;  /* --ambient CELSIUS (default 25) */
  double angle_deg;  /* --angle DEG: output angle at start (default 150, the centre) */
  ax12_load_t load;  /* --load-torque / --load-spring / --load-arm (default none) */
  const char *load_option; /* the load option given, for "only one load" */
} plant_options_t;

void plant_options_default(plant_options_t *o);

/* Parses one option's value: option is the name without dashes ("supply", "ambient", "angle",
 * "load-torque", "load-spring", "load-arm"). Returns false with a one-line message in err. */
bool plant_options_parse(plant_options_t *o, const char *option, const char *value, char *err, size_t err_len);

/* A plant in that world, at rest. */
void plant_options_build(const plant_options_t *o, ax12_plant_t *plant);

/* getopt_long codes of the world options, shared by every program that takes them (a program
 * numbers its own options from 256, below PLANT_OPT_SUPPLY). */
enum {
  PLANT_OPT_SUPPLY = 0x400,
  PLANT_OPT_AMBIENT,
  PLANT_OPT_ANGLE,
  PLANT_OPT_LOAD_TORQUE,
  PLANT_OPT_LOAD_SPRING,
  PLANT_OPT_LOAD_ARM,
  PLANT_OPT_END
};

/* The world options as `struct option` entries for a program's long_options table (the
 * program includes <getopt.h>). */
#define PLANT_LONG_OPTIONS                                                                                          \
  {"supply", required_argument, NULL, PLANT_OPT_SUPPLY}, {"ambient", required_argument, NULL, PLANT_OPT_AMBIENT},  \
      {"angle", required_argument, NULL, PLANT_OPT_ANGLE},                                                         \
      {"load-torque", required_argument, NULL, PLANT_OPT_LOAD_TORQUE},                                             \
      {"load-spring", required_argument, NULL, PLANT_OPT_LOAD_SPRING},                                             \
      {"load-arm", required_argument, NULL, PLANT_OPT_LOAD_ARM}

/* The option name (without dashes) of a getopt code, NULL when it is not a world option. */
const char *plant_option_name(int code);

/* Help lines for the options. */
extern const char plant_options_help[];

#endif
