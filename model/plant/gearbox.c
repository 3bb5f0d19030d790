#include "gearbox.h"

#include <math.h>

double ax12_gearbox_drive_nm(const ax12_gearbox_params_t *g, double motor_nm)
{
    return g->ratio * motor_nm;
}

double ax12_gearbox_motor_rad_s(const ax12_gearbox_params_t *g, double output_rad_s)
{
    return g->ratio * output_rad_s;
}

double ax12_gearbox_drive_share(const ax12_gearbox_params_t *g, double drive_sign,
                                double dir_sign)
{
    return 1.0 - drive_sign * dir_sign * (1.0 - g->efficiency);
}

double ax12_gearbox_sliding_friction_nm(const ax12_gearbox_params_t *g, double drive_nm)
{
    return g->coulomb_nm + (1.0 - g->efficiency) * fabs(drive_nm);
}

double ax12_gearbox_breakaway_friction_nm(const ax12_gearbox_params_t *g, double drive_nm)
{
    return g->static_nm + (1.0 - g->efficiency) * fabs(drive_nm);
}

double ax12_gearbox_output_inertia_kg_m2(const ax12_gearbox_params_t *g,
                                         double motor_inertia_kg_m2)
{
    return g->inertia_kg_m2 + g->ratio * g->ratio * motor_inertia_kg_m2;
}
