/* The servo's control: one fixed-rate tick that turns sensor readings and the control table
 * into a motor drive, publishes the Present* items and Moving, and runs the alarms.
 *
 * Units: position in pot counts (0..1023 over 300 degrees, 3.41 counts per degree); drive in
 * 1/1023 of full supply, signed, positive = counter-clockwise (CCW, counts rising); Moving
 * Speed and Present Speed in 0.111 rpm per unit (2.2711 counts/s per unit).
 *
 * Joint mode (docs/policy.md "Motion semantics"): a setpoint moves toward the goal (clamped to the
 * angle limits) at Moving Speed (0 = jumps there). The compliance law acts on
 * e = setpoint - position: |e| <= margin gives no drive; past the margin the drive steps to
 * Punch and rises linearly to Torque Limit over the slope, where slope s acts as the smallest
 * power of two >= s (2..256). CW margin/slope apply when the position lies CW of the setpoint.
 * Wheel mode (both angle limits 0): Moving Speed bits 0..9 are the drive, bit 10 the
 * direction (1 = CW); Torque Limit caps it.
 *
 * Alarms (docs/policy.md "Alarms"): conditions voltage, overheating and overload are held in
 * servo->held_conditions; the angle-limit condition comes from the core; events come from
 * dxl_servo_take_events(). A bit set in Alarm LED blinks the LED while it holds and for
 * DXL_ALARM_LED_HOLD_MS after; a bit set in Alarm Shutdown turns torque off (Torque Enable
 * reads 0; in profile ax12a Torque Limit is also set to 0) until Torque Enable is written 1.
 *
 * Overload: the drive is at Torque Limit (the error lies past margin + slope, or past the margin
 * when Punch >= Torque Limit, or the wheel-mode drive is capped) while the output does not
 * follow it (Present Speed in the drive's direction under DXL_OVERLOAD_STALL_SPEED: stalled, or
 * dragged backwards by its load) for DXL_OVERLOAD_WINDOW_MS in a row. Once
 * tripped, the condition holds while that lasts, and while torque is off, until Torque Enable
 * is written 1 (so the reason for a shutdown stays visible in the error byte).
 *
 * Budget: one call per DXL_CONTROL_PERIOD_US, from the main loop; no division on the AVR
 * except by powers of two.
 */
#ifndef DXL_CONTROL_H
#define DXL_CONTROL_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_servo.h"

#define DXL_CONTROL_PERIOD_US 1000u
#define DXL_DRIVE_MAX 1023
#define DXL_OVERLOAD_WINDOW_MS 1000u
#define DXL_OVERLOAD_STALL_SPEED 20u /* Present Speed units, about 2.2 rpm */
#define DXL_ALARM_LED_HOLD_MS 2000u
#define DXL_ALARM_BLINK_HALF_PERIOD_MS 250u
#define DXL_ARRIVAL_TOLERANCE_COUNTS 2u /* Moving clears within margin + this */

/* Moving Speed unit in setpoint steps: 2.2711 counts/s = 148.8 (counts << 16) per 1 ms tick. */
#define DXL_SPEED_UNIT_Q16_PER_TICK 149L

typedef struct {
  uint16_t position_counts; /* pot, 0..1023 */
  uint8_t voltage_dv;       /* supply, volts x 10 */
  uint8_t temperature_c;
} dxl_sensors_t;

typedef struct {
  int32_t setpoint_q16;   /* motion setpoint, counts << 16 */
  int16_t speed_x8;       /* filtered speed, Present Speed units x 8, + = CCW */
  uint16_t last_position_counts;
  uint16_t overload_ms;   /* how long the overload test has held */
  uint16_t alarm_led_ms;  /* remaining blink time after the last alarm */
  uint16_t blink_phase_ms;
  bool torque_was_enabled;
  bool started;
  uint8_t conditions; /* dxl_servo_conditions() as the last tick saw them */
} dxl_control_t;

void dxl_control_init(dxl_control_t *control);

/* One control tick: publishes Present Position, Speed, Load, Voltage, Temperature and Moving
 * into servo->table, updates the held conditions, applies Alarm Shutdown, and returns the
 * drive (-DXL_DRIVE_MAX..DXL_DRIVE_MAX). *led_on is the LED output (register 25, or the
 * alarm blink while an alarm holds). */
int16_t dxl_control_tick(dxl_control_t *control, dxl_servo_t *servo, const dxl_sensors_t *sensors, bool *led_on);

/* What a committed write decides at once of the items the tick derives (docs/policy.md
 * "Motion semantics"), so the first status a client can read after it agrees with it: with
 * torque on, Moving reads 1 once the goal (clamped to the angle limits) lies farther from
 * Present Position than the compliance margin on its side plus DXL_ARRIVAL_TOLERANCE_COUNTS,
 * or a wheel-mode speed is set that Torque Limit lets through; with torque off, Moving and
 * Present Load read 0. The next tick goes on from there. */
void dxl_control_after_write(uint8_t *table);

/* The effective compliance slope: the smallest power of two >= slope, as a shift (1..8). */
uint8_t dxl_control_slope_shift(uint8_t slope);

/* PWM duty (0..255) of a drive magnitude (0..DXL_DRIVE_MAX): floor(magnitude x 255 / 1023),
 * without a multiply (see dxl_control.c). */
uint8_t dxl_control_duty(uint16_t magnitude);

/* Drive for a position error (counts, positive = position lies CW of the setpoint) under the
 * compliance law. */
int16_t dxl_control_compliance_drive(int16_t error_counts, uint8_t cw_margin, uint8_t ccw_margin, uint8_t cw_slope,
                                     uint8_t ccw_slope, uint16_t punch, uint16_t torque_limit);

#endif
