/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include <math.h>
#include <stdio.h>

#include "lab_experiments.h"

/* A stall at full drive against a spring until the overheating alarm, and a minute after. */
int lab_heating(const lab_options_t *o) {
  lab_t lab;
  const ax12_plant_t plant = lab_plant(o, o->world.supply_v, 0.1);
  lab_open(&lab, o, &plant);
  lab_write_u8(&lab, CT_ADDR_ALARM_LED, 0x04);
  lab_write_u8(&lab, CT_ADDR_ALARM_SHUTDOWN, 0x04); /* overheating only: the stall itself may go on */
  const uint8_t limit = lab_read_u8(&lab, CT_ADDR_HIGHEST_LIMIT_TEMP);
  lab_write_u16(&lab, CT_ADDR_GOAL_POSITION, 1000);
  lab_write_u8(&lab, CT_ADDR_TORQUE_ENABLE, 1);
  /* A stiff spring toward 150 deg: the servo winds it up a little and stalls at full drive. */
  lab_set_load(&lab, ax12_load_spring(20.0, 150.0 / LAB_DEG_PER_RAD));
  printf("t_s,present_temperature,limit,case_c,winding_c,current_a,torque_enable\n");
  const double t0 = lab_now_ms(&lab);
  double off_since = -1.0;
  for (;;) {
    const double t = (lab_now_ms(&lab) - t0) / 1000.0;
    const int temp = lab_read_u8(&lab, CT_ADDR_PRESENT_TEMPERATURE);
    const int enabled = lab_read_u8(&lab, CT_ADDR_TORQUE_ENABLE);
    const ax12_plant_t *p = &lab.servo->plant;
    printf("%.1f,%d,%u,%.2f,%.2f,%.3f,%d\n", t, temp, limit, ax12_plant_case_temp_c(p), ax12_plant_winding_temp_c(p),
           ax12_plant_supply_current_a(p), enabled);
    if (!enabled && off_since < 0.0) {
      off_since = t;
    }
    if ((off_since >= 0.0 && t > off_since + 60.0) || t > 900.0) {
      break;
    }
    lab_run_ms(&lab, 500.0);
  }
  lab_close(&lab);
  return 0;
}

