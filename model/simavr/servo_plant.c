/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "servo_plant.h"

#include <sim_avr.h>

void servo_show_plant(servo_t *servo) {
  if (!servo->has_plant) {
    return;
  }
  const ax12_plant_t *p = &servo->plant;
  board_set_analog_mv(&servo->board, ax12_plant_pot_mv(p), ax12_plant_supply_sense_mv(p), ax12_plant_temp_sense_mv(p));
}

void servo_attach_plant(servo_t *servo, const ax12_plant_t *plant) {
  servo->plant = *plant;
  servo->has_plant = true;
  servo->plant_at = servo->avr->cycle;
  if (servo->plant_due && servo->plant_at + SERVO_PLANT_STEP < *servo->plant_due) {
    *servo->plant_due = servo->plant_at + SERVO_PLANT_STEP;
  }
  servo_show_plant(servo);
}

void servo_step_plant(servo_t *servo, sim_cycles_t now, bool force) {
  if (!servo->has_plant || now <= servo->plant_at || (!force && now - servo->plant_at < SERVO_PLANT_STEP)) {
    return;
  }
  const double dt_s = (double)(now - servo->plant_at) / SIM_CPU_HZ;
  if (servo->plant_on_joint) {
    ax12_plant_joint_step(&servo->plant, board_pwm_duty(&servo->board), dt_s, &servo->joint_drive);
  } else {
    ax12_plant_step(&servo->plant, board_pwm_duty(&servo->board), dt_s);
  }
  servo->plant_at = now;
  servo_show_plant(servo);
}
