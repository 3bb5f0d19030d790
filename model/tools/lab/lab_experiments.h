/* SPDX-License-Identifier: GPL-3.0-or-later */
/* ax12-lab's experiments, one module each; each writes CSV (a header line, then rows) to
 * stdout and returns the exit status. */
#ifndef LAB_EXPERIMENTS_H
#define LAB_EXPERIMENTS_H

#include <stdint.h>

#include "lab_client.h"

#define LAB_RPM_PER_RAD_S (60.0 / (2.0 * M_PI))
#define LAB_DEG_PER_RAD (180.0 / M_PI)

int lab_step(const lab_options_t *o);        /* lab_step.c */
int lab_compliance(const lab_options_t *o);  /* lab_compliance.c */
int lab_speed_load(const lab_options_t *o);  /* lab_speed_load.c */
int lab_heating(const lab_options_t *o);     /* lab_heating.c */
int lab_report(const lab_options_t *o);      /* lab_report.c */

/* Wheel mode (lab_speed_load.c): the means over the measuring window. */
typedef struct {
  double present_speed; /* mean Present Speed, units (signed) */
  double protocol_rpm;  /* from Present Position over the window */
  double plant_rpm;     /* the shaft's mean speed over the window */
  double present_load;
  double current_a;     /* mean supply current */
} lab_wheel_result_t;

/* Wheel mode at drive `drive` (bits 0..9, CCW) against a constant CW load of load_nm N m from
 * rest at 20 deg: 300 ms to settle, then 300 ms of readings every 10 ms. */
lab_wheel_result_t lab_wheel_run(const lab_options_t *o, double supply_v, double load_nm, uint16_t drive);

#endif
