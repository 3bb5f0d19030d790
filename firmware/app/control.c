/* The control tick (docs/control.md): the compliance position loop, wheel mode, Present*
 * and the alarms of firmware/core/dxl_control.c, wired to the H-bridge and the LED. */
#include "control.h"

#include "dxl_control.h"
#include "dxl_table.h"
#include "motor.h"

static dxl_control_t control;
static bool led_on;
static uint8_t voltage_dv;

uint8_t control_tick(dxl_servo_t *servo) {
  /* The ADC readings of this tick are already in the table (main.c publishes them). A factory
   * reset clears them until the next conversion of each (Present Voltage: up to 4 ms); a
   * powered servo never reads 0 V, so 0 keeps the last voltage (no input-voltage glitch). */
  if (servo->table[CT_ADDR_PRESENT_VOLTAGE] != 0) {
    voltage_dv = servo->table[CT_ADDR_PRESENT_VOLTAGE];
  }
  const dxl_sensors_t sensors = {
      .position_counts = ct_get_u16(servo->table, CT_ADDR_PRESENT_POSITION),
      .voltage_dv = voltage_dv,
      .temperature_c = servo->table[CT_ADDR_PRESENT_TEMPERATURE],
  };
  const int16_t drive = dxl_control_tick(&control, servo, &sensors, &led_on);
  const int16_t duty = dxl_control_duty((uint16_t)(drive < 0 ? -drive : drive));
  motor_set_drive(drive < 0 ? (int16_t)-duty : duty);
  return control.conditions;
}

bool control_led_on(void) { return led_on; }
