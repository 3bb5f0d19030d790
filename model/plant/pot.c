#include "pot.h"

#include <math.h>

#define AX12_TWO_PI 6.283185307179586

static double wrap_turn_rad(double angle_rad)
{
    double a = fmod(angle_rad, AX12_TWO_PI);
    return a < 0.0 ? a + AX12_TWO_PI : a;
}

bool ax12_pot_in_dead_band(const ax12_pot_params_t *p, double angle_rad)
{
    return wrap_turn_rad(angle_rad) > p->track_rad;
}

double ax12_pot_mv(const ax12_pot_params_t *p, double angle_rad)
{
    double a = wrap_turn_rad(angle_rad);
    if (a > p->track_rad) {
        return p->dead_band_mv;
    }
    return p->full_scale_mv * a / p->track_rad;
}
