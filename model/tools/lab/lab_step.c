/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include <math.h>
#include <stdio.h>

#include "lab_experiments.h"

/* Present Position after a goal step 412 -> 612, for each compliance slope. */
int lab_step(const lab_options_t *o) {
  static const uint8_t slopes[] = {8, 16, 17, 32, 64, 128};
  printf("slope,t_ms,goal,position,speed,load\n");
  for (size_t k = 0; k < sizeof(slopes); k++) {
    lab_t lab;
    const ax12_plant_t plant = lab_plant(o, o->world.supply_v, 0.1);
    lab_open(&lab, o, &plant);
    lab_write_u8(&lab, CT_ADDR_CW_COMPLIANCE_SLOPE, slopes[k]);
    lab_write_u8(&lab, CT_ADDR_CCW_COMPLIANCE_SLOPE, slopes[k]);
    lab_write_u16(&lab, CT_ADDR_GOAL_POSITION, 412);
    lab_write_u8(&lab, CT_ADDR_TORQUE_ENABLE, 1);
    lab_run_ms(&lab, 600.0);
    const double t0 = lab_now_ms(&lab);
    lab_write_u16(&lab, CT_ADDR_GOAL_POSITION, 612);
    for (;;) {
      const double t = lab_now_ms(&lab) - t0;
      if (t > 800.0) {
        break;
      }
      const lab_present_t p = lab_read_present(&lab);
      printf("%u,%.2f,612,%d,%d,%d\n", slopes[k], t, p.position, p.speed, p.load);
      lab_run_ms(&lab, 2.0);
    }
    lab_close(&lab);
  }
  return 0;
}

