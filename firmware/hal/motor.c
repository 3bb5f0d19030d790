/* H-bridge PWM. See motor.h. */
#include "motor.h"

#include <avr/io.h>

#define TCCR0A_FAST_PWM (_BV(WGM01) | _BV(WGM00))
#define TCCR0B_RUN _BV(CS00) /* no prescaler: 62.5 kHz */

static int16_t applied_drive; /* registers are written only when the drive changes */

void motor_init(void) {
  PORTD &= (uint8_t)~(_BV(PD5) | _BV(PD6));
  DDRD |= _BV(PD5) | _BV(PD6);
  OCR0A = 0;
  OCR0B = 0;
  TCCR0A = TCCR0A_FAST_PWM;
  TCCR0B = 0; /* stopped until the first drive */
}

void motor_set_drive(int16_t drive) {
  if (drive > MOTOR_DRIVE_MAX) {
    drive = MOTOR_DRIVE_MAX;
  } else if (drive < -MOTOR_DRIVE_MAX) {
    drive = -MOTOR_DRIVE_MAX;
  }
  if (drive == applied_drive) {
    return;
  }
  /* The timer runs only while the motor is driven: it starts when the drive leaves 0 (here
   * drive != 0), before a duty is written (a compare value written to a stopped timer reaches
   * no pin before the next start); from one drive to another it keeps running. */
  if (applied_drive == 0) {
    TCCR0B = TCCR0B_RUN;
  }
  applied_drive = drive;
  /* The other side goes to 0 first: never both non-zero. */
  if (drive > 0) {
    OCR0B = 0;
    TCCR0A = TCCR0A_FAST_PWM | _BV(COM0A1);
    OCR0A = (uint8_t)drive;
  } else if (drive < 0) {
    OCR0A = 0;
    TCCR0A = TCCR0A_FAST_PWM | _BV(COM0B1);
    OCR0B = (uint8_t)-drive;
  } else {
    TCCR0A = TCCR0A_FAST_PWM;
    OCR0A = 0;
    OCR0B = 0;
    TCCR0B = 0; /* coast: both pins are port outputs (low), the timer has nothing to do */
  }
}
