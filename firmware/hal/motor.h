/* H-bridge drive on Timer0 (docs/hardware.md "H-bridge PWM"): fast PWM, TOP 0xFF, no
 * prescaler (62.5 kHz). OC0A (PD6) drives counter-clockwise (position rising), OC0B (PD5)
 * clockwise; at most one of OCR0A / OCR0B is non-zero; both 0 = coast, with Timer0 stopped
 * (it runs only while the motor is driven).
 *
 * The motion control's seam: control_tick() (app/control.c) computes a drive and calls
 * motor_set_drive() once per control tick. Main loop only.
 */
#ifndef HAL_MOTOR_H
#define HAL_MOTOR_H

#include <stdint.h>

#define MOTOR_DRIVE_MAX 255

/* Both duties 0 (coast), Timer0 stopped. */
void motor_init(void);

/* drive: -255..255 (clamped); > 0 counter-clockwise (OCR0A = drive), < 0 clockwise
 * (OCR0B = -drive), 0 coast. The motor sees supply x drive / 255 on average. A zero duty
 * also disconnects its pin from the timer (fast PWM would still emit a one-cycle spike); a zero
 * drive also stops Timer0. */
void motor_set_drive(int16_t drive);

#endif
