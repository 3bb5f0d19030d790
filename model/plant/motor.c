#include "motor.h"

#include <math.h>

double ax12_motor_resistance_ohm(const ax12_motor_params_t *m, double winding_c)
{
    return m->r_25c_ohm * (1.0 + m->r_tempco_per_c * (winding_c - 25.0));
}

double ax12_motor_backemf_v(const ax12_motor_params_t *m, double motor_rad_s)
{
    return m->kt_nm_a * motor_rad_s;
}

double ax12_motor_torque_nm(const ax12_motor_params_t *m, double current_a)
{
    return m->kt_nm_a * current_a;
}

double ax12_motor_friction_nm(const ax12_motor_params_t *m)
{
    return m->kt_nm_a * fabs(m->i_noload_a);
}

double ax12_motor_current_a(const ax12_motor_params_t *m, double v_avg_v,
                            double motor_rad_s, double r_loop_ohm)
{
    return (v_avg_v - ax12_motor_backemf_v(m, motor_rad_s)) / r_loop_ohm;
}
