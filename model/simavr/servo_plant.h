/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A servo's physics (model/plant) behind its board: the plant is stepped with the H-bridge
 * duty the board records and shows its pot, supply and temperature voltages on the board's
 * analog pins. The world steps every plant at most SERVO_PLANT_STEP apart. */
#ifndef SIM_SERVO_PLANT_H
#define SIM_SERVO_PLANT_H

#include <stdbool.h>

#include "plant.h"
#include "servo.h"
#include "sim_time.h"

/* Plant step: at most this much simulated time between two plant steps (100 us). */
#define SERVO_PLANT_STEP ((sim_cycles_t)100u * SIM_CYCLES_PER_US)

/* Gives the servo a plant (copied), whose readings the board shows from now on. The plant's
 * clock starts at the servo's. */
void servo_attach_plant(servo_t *servo, const ax12_plant_t *plant);

/* Steps the plant to now if it lags by SERVO_PLANT_STEP or more (force: whatever the lag),
 * with the H-bridge duty of the board, and feeds its readings to the board. A plant whose
 * output is a robot's joint (servo_t.plant_on_joint) steps its electrics only
 * (ax12_plant_joint_step): the robot's physics moves the shaft. */
void servo_step_plant(servo_t *servo, sim_cycles_t now, bool force);

/* Shows the plant's readings on the board (after changing the plant's state directly). */
void servo_show_plant(servo_t *servo);

#endif
