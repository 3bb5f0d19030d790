/* The control seam: what runs once per control tick (1 kHz, timebase.h) in the main loop,
 * after the ADC readings of that tick are in the control table.
 *
 * Contract for the motion control to come (compliance position loop, alarms, Present Speed /
 * Load / Moving): read the table and held conditions of *servo, write the Present* items and
 * servo->held_conditions, and drive the motor only through motor_set_drive(). It runs in the
 * main loop, never in an ISR, so it may take a few hundred microseconds; a packet arriving
 * meanwhile waits in the UART ring (64 bytes = 640 us at 1 Mbps).
 */
#ifndef APP_CONTROL_H
#define APP_CONTROL_H

#include "dxl_servo.h"

void control_tick(dxl_servo_t *servo);

#endif
