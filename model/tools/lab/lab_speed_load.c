/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include <math.h>
#include <stdio.h>

#include "lab_experiments.h"

lab_wheel_result_t lab_wheel_run(const lab_options_t *o, double supply_v, double load_nm, uint16_t drive) {
  lab_t lab;
  ax12_plant_t plant = lab_plant(o, supply_v, 0.0);
  ax12_plant_set_angle_rad(&plant, 20.0 / LAB_DEG_PER_RAD);
  lab_open(&lab, o, &plant);
  lab_write_u16(&lab, CT_ADDR_CW_ANGLE_LIMIT, 0);
  lab_write_u16(&lab, CT_ADDR_CCW_ANGLE_LIMIT, 0);
  lab_write_u8(&lab, CT_ADDR_TORQUE_ENABLE, 1);
  lab_set_load(&lab, ax12_load_constant(-load_nm));
  lab_write_u16(&lab, CT_ADDR_MOVING_SPEED, drive);
  lab_run_ms(&lab, 300.0);
  lab_wheel_result_t r = {0};
  const double a0 = ax12_plant_angle_rad(&lab.servo->plant);
  const double t0 = lab_now_ms(&lab);
  const lab_present_t first = lab_read_present(&lab);
  int n = 0;
  lab_present_t p = first;
  for (int i = 0; i < 30; i++) {
    lab_run_ms(&lab, 10.0);
    p = lab_read_present(&lab);
    r.present_speed += p.speed;
    r.present_load += p.load;
    r.current_a += ax12_plant_supply_current_a(&lab.servo->plant);
    n++;
  }
  const double dt_s = (lab_now_ms(&lab) - t0) / 1000.0;
  r.present_speed /= n;
  r.present_load /= n;
  r.current_a /= n;
  r.plant_rpm = (ax12_plant_angle_rad(&lab.servo->plant) - a0) / dt_s * LAB_RPM_PER_RAD_S;
  r.protocol_rpm = (p.position - first.position) * (300.0 / 1024.0) / 360.0 / dt_s * 60.0;
  lab_close(&lab);
  return r;
}

/* Wheel mode at full drive against constant loads, for each supply. */
int lab_speed_load(const lab_options_t *o) {
  static const double supplies[] = {7.0, 9.6, 10.0, 12.0};
  printf("supply_v,load_nm,present_speed,protocol_rpm,plant_rpm,present_load\n");
  for (size_t s = 0; s < sizeof(supplies) / sizeof(supplies[0]); s++) {
    for (double load = 0.0; load < 2.6; load += 0.1) {
      const lab_wheel_result_t r = lab_wheel_run(o, supplies[s], load, 1023);
      printf("%.1f,%.2f,%.1f,%.2f,%.2f,%.0f\n", supplies[s], load, r.present_speed, r.protocol_rpm, r.plant_rpm,
             r.present_load);
      fflush(stdout);
      if (r.plant_rpm <= 0.05) {
        break;
      }
    }
  }
  return 0;
}

