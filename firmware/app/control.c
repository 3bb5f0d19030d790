/* The control tick (docs/control.md): the compliance position loop, wheel mode, Present*
 * and the alarms of firmware/core/dxl_control.c, wired to the H-bridge and the LED. */
#include "control.h"

#include "dxl_control.h"
#include "motor.h"

static dxl_control_t control;
static bool led_on;

uint8_t control_tick(dxl_servo_t *servo, const dxl_sensors_t *sensors) {
  const int16_t drive = dxl_control_tick(&control, servo, sensors, &led_on);
  const int16_t duty = dxl_control_duty((uint16_t)(drive < 0 ? -drive : drive));
  motor_set_drive(drive < 0 ? (int16_t)-duty : duty);
  return control.conditions;
}

bool control_led_on(void) { return led_on; }
