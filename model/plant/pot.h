/* Potentiometer on the output shaft, wiper to ADC0 (docs/hardware.md).
 *
 * The resistive track covers track_rad (300 deg) from the clockwise end
 * (output angle 0, 0 mV) to the counter-clockwise end (full_scale_mv, 5000 mV),
 * linear in between; the 10-bit ADC reads 0..1023 over it. The shaft turns
 * endlessly: the angle is taken modulo one turn. Over the remaining 60 deg the
 * wiper is off the track and the pull-down on the wiper line holds it at
 * dead_band_mv (0 mV by default: the servo believes it sits at the CW end). */
#ifndef AX12_PLANT_POT_H
#define AX12_PLANT_POT_H

#include <stdbool.h>

typedef struct {
    double track_rad;      /* electrical travel: 300 deg */
    double full_scale_mv;  /* wiper at the CCW end of the track: 5000 mV */
    double dead_band_mv;   /* wiper off the track */
} ax12_pot_params_t;

/* Wiper voltage at output angle angle_rad (any value; wrapped to one turn). */
double ax12_pot_mv(const ax12_pot_params_t *p, double angle_rad);

/* True when angle_rad (wrapped to one turn) is off the track. */
bool ax12_pot_in_dead_band(const ax12_pot_params_t *p, double angle_rad);

#endif
