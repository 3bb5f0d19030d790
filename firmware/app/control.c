/* The control tick (docs/control.md): the compliance position loop, wheel mode, Present*
 * and the alarms of firmware/core/dxl_control.c, wired to the H-bridge and the LED. */
#include "control.h"

#include "dxl_control.h"
#include "dxl_table.h"
#include "motor.h"

/* drive (0..1023) to duty (0..255) = drive x 255 / 1023, floored: exactly drive x 1021 >> 12
 * for every drive 0..1023 (checked exhaustively; no division on the AVR). */
#define DRIVE_TO_DUTY_MUL 1021u
#define DRIVE_TO_DUTY_SHIFT 12u

static dxl_control_t control;
static bool led_on;
static uint8_t voltage_dv;

void control_tick(dxl_servo_t *servo) {
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
  const uint16_t magnitude = (uint16_t)(drive < 0 ? -drive : drive);
  /* >> 12 as a byte move (>> 8) and >> 4 on 16 bits: a 32-bit shift is a 12-turn loop. */
  const int16_t duty = (int16_t)((uint16_t)(((uint32_t)magnitude * DRIVE_TO_DUTY_MUL) >> 8) >> (DRIVE_TO_DUTY_SHIFT - 8u));
  motor_set_drive(drive < 0 ? (int16_t)-duty : duty);
}

bool control_led_on(void) { return led_on; }
