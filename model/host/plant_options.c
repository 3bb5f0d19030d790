/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "plant_options.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEG_PER_RAD (180.0 / M_PI)

const char plant_options_help[] =
    "  --supply VOLTS      supply voltage at the source, 0.1..30 (default 9.6; 0.1 ohm\n"
    "                      source resistance)\n"
    "  --ambient CELSIUS   air temperature, -40..150 (default 25)\n"
    "  --angle DEG         output angle at start, 0..360 (default 150, the centre;\n"
    "                      0..300 is the pot track, count = DEG x 1024 / 300)\n"
    "  --load-torque NM    constant torque on the output, -10..10 N m (+ = CCW)\n"
    "  --load-spring K[,REST_DEG]  spring of K N m/rad (0..100) toward REST_DEG\n"
    "                      (default 150)\n"
    "  --load-arm KG,METRES[,HORIZONTAL_DEG]  a mass on an arm under gravity (0..10 kg,\n"
    "                      0..1 m); the arm is horizontal at HORIZONTAL_DEG (default 150)\n"
    "                      and turning CCW lifts it\n"
    "                      (one load option at most; default: no load)\n";

void plant_options_default(plant_options_t *o) {
  memset(o, 0, sizeof(*o));
  o->supply_v = 9.6;
  o->ambient_c = 25.0;
  o->angle_deg = 150.0;
  o->load = ax12_load_none();
}

/* Parses up to max comma-separated numbers; returns how many, -1 on a bad one. */
static int parse_numbers(const char *text, double *out, int max) {
  int n = 0;
  const char *p = text;
  while (n < max) {
    char *end = NULL;
    errno = 0;
    const double v = strtod(p, &end);
    if (errno || end == p || !isfinite(v)) {
      return -1;
    }
    out[n++] = v;
    if (*end == '\0') {
      return n;
    }
    if (*end != ',') {
      return -1;
    }
    p = end + 1;
  }
  return -1; /* more values than allowed */
}

const char *plant_option_name(int code) {
  static const char *const names[PLANT_OPT_END - PLANT_OPT_SUPPLY] = {"supply",      "ambient",     "angle",
                                                                        "load-torque", "load-spring", "load-arm"};
  return (code >= PLANT_OPT_SUPPLY && code < PLANT_OPT_END) ? names[code - PLANT_OPT_SUPPLY] : NULL;
}

static bool in_range(double v, double lo, double hi) { return v >= lo && v <= hi; }

bool plant_options_parse(plant_options_t *o, const char *option, const char *value, char *err, size_t err_len) {
  double v[3];
  const int n = parse_numbers(value, v, 3);
  const bool is_load = strncmp(option, "load-", 5) == 0;
  if (is_load && o->load_option && strcmp(o->load_option, option) != 0) {
    snprintf(err, err_len, "--%s and --%s: one load at a time", o->load_option, option);
    return false;
  }
  if (strcmp(option, "supply") == 0) {
    if (n != 1 || !in_range(v[0], 0.1, 30.0)) {
      snprintf(err, err_len, "bad --supply '%s': volts, 0.1..30", value);
      return false;
    }
    o->supply_v = v[0];
  } else if (strcmp(option, "ambient") == 0) {
    if (n != 1 || !in_range(v[0], -40.0, 150.0)) {
      snprintf(err, err_len, "bad --ambient '%s': degrees C, -40..150", value);
      return false;
    }
    o->ambient_c = v[0];
  } else if (strcmp(option, "angle") == 0) {
    if (n != 1 || !in_range(v[0], 0.0, 360.0)) {
      snprintf(err, err_len, "bad --angle '%s': degrees, 0..360", value);
      return false;
    }
    o->angle_deg = v[0];
  } else if (strcmp(option, "load-torque") == 0) {
    if (n != 1 || !in_range(v[0], -10.0, 10.0)) {
      snprintf(err, err_len, "bad --load-torque '%s': N m, -10..10", value);
      return false;
    }
    o->load = ax12_load_constant(v[0]);
  } else if (strcmp(option, "load-spring") == 0) {
    if (n < 1 || !in_range(v[0], 0.0, 100.0) || (n == 2 && !in_range(v[1], 0.0, 360.0)) || n > 2) {
      snprintf(err, err_len, "bad --load-spring '%s': K[,REST_DEG], K 0..100 N m/rad, REST_DEG 0..360", value);
      return false;
    }
    o->load = ax12_load_spring(v[0], (n == 2 ? v[1] : 150.0) / DEG_PER_RAD);
  } else if (strcmp(option, "load-arm") == 0) {
    if (n < 2 || !in_range(v[0], 0.0, 10.0) || !in_range(v[1], 0.0, 1.0) || (n == 3 && !in_range(v[2], 0.0, 360.0))) {
      snprintf(err, err_len, "bad --load-arm '%s': KG,METRES[,HORIZONTAL_DEG], 0..10 kg, 0..1 m", value);
      return false;
    }
    o->load = ax12_load_arm(v[0], v[1], (n == 3 ? v[2] : 150.0) / DEG_PER_RAD);
  } else {
    snprintf(err, err_len, "unknown world option --%s", option);
    return false;
  }
  if (is_load) {
    o->load_option = option;
  }
  return true;
}

void plant_options_build(const plant_options_t *o, ax12_plant_t *plant) {
  ax12_plant_params_t params = ax12_plant_params_default();
  params.supply.source_v = o->supply_v;
  params.ambient_c = o->ambient_c;
  ax12_plant_init(plant, &params);
  ax12_plant_set_load(plant, &o->load);
  ax12_plant_set_angle_rad(plant, o->angle_deg / DEG_PER_RAD);
}
