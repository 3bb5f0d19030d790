/* The control tick. No motion control yet: the motor coasts whatever the table says. */
#include "control.h"

#include "motor.h"

void control_tick(dxl_servo_t *servo) {
  (void)servo;
  motor_set_drive(0);
}
