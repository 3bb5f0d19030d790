/* The control seam: what runs once per control tick (1 kHz, timebase.h) in the main loop,
 * after the ADC reading of that tick is in the sensors.
 *
 * control_tick() runs dxl_control_tick() (firmware/core/dxl_control.h, docs/control.md) on
 * the latest readings of pot, supply and temperature (the main loop keeps them, one ADC
 * conversion a tick) and sets the H-bridge:
 * drive -1023..1023 -> motor_set_drive(drive x 255 / 1023, floored: dxl_control_duty()).
 * Contract: read the table and held conditions of *servo, write the Present* items and
 * servo->held_conditions, and drive the motor only through motor_set_drive(). It runs in the
 * main loop, never in an ISR (a whole tick is about 1.0k cycles, 65 us, docs/control.md
 * "Cost"); a packet arriving meanwhile waits in the UART ring (UART_RX_RING_BYTES = 128
 * bytes = 1.28 ms at 1 Mbps).
 */
#ifndef APP_CONTROL_H
#define APP_CONTROL_H

#include <stdbool.h>

#include "dxl_control.h"
#include "dxl_servo.h"

/* Returns the conditions that hold after it (dxl_servo_conditions(servo): nothing else in the
 * tick changes them), for the ready PING reply. */
uint8_t control_tick(dxl_servo_t *servo, const dxl_sensors_t *sensors);

/* The LED as the control wants it after the last tick: register 25 (LED), or the alarm blink
 * while an alarm whose bit is set in Alarm LED holds and for 2 s after (docs/policy.md "Alarms").
 * The main loop shows this once the power-up blink is over. */
bool control_led_on(void);

#endif
