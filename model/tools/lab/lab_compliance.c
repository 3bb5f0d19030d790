/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include <math.h>
#include <stdio.h>

#include "lab_experiments.h"

/* Present Load against the position error under a load torque swept 0 -> +2 -> -2 -> 0 N m, for each
 * compliance slope. */
int lab_compliance(const lab_options_t *o) {
  static const uint8_t slopes[] = {16, 32, 64, 128};
  const double peak_nm = 2.0, period_ms = 8000.0;
  printf("slope,t_ms,load_nm,goal,position,error,present_load\n");
  for (size_t k = 0; k < sizeof(slopes); k++) {
    lab_t lab;
    const ax12_plant_t plant = lab_plant(o, o->world.supply_v, 0.1);
    lab_open(&lab, o, &plant);
    lab_write_u8(&lab, CT_ADDR_CW_COMPLIANCE_MARGIN, 1);
    lab_write_u8(&lab, CT_ADDR_CCW_COMPLIANCE_MARGIN, 1);
    lab_write_u8(&lab, CT_ADDR_CW_COMPLIANCE_SLOPE, slopes[k]);
    lab_write_u8(&lab, CT_ADDR_CCW_COMPLIANCE_SLOPE, slopes[k]);
    lab_write_u16(&lab, CT_ADDR_PUNCH, 32);
    lab_write_u16(&lab, CT_ADDR_GOAL_POSITION, 512);
    lab_write_u8(&lab, CT_ADDR_TORQUE_ENABLE, 1);
    lab_run_ms(&lab, 300.0);
    const double t0 = lab_now_ms(&lab);
    for (;;) {
      const double t = lab_now_ms(&lab) - t0;
      if (t > period_ms) {
        break;
      }
      /* Triangle 0 -> +peak -> -peak -> 0: the load pushes CCW, then CW. */
      const double x = t / period_ms;
      const double load = peak_nm * (x < 0.25 ? 4.0 * x : (x < 0.75 ? 2.0 - 4.0 * x : 4.0 * x - 4.0));
      lab_set_load(&lab, ax12_load_constant(load));
      const lab_present_t p = lab_read_present(&lab);
      printf("%u,%.1f,%.4f,512,%d,%d,%d\n", slopes[k], t, load, p.position, 512 - p.position, p.load);
      lab_run_ms(&lab, 10.0);
    }
    lab_close(&lab);
  }
  return 0;
}

