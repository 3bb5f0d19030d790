#include "thermal.h"

void ax12_thermal_init(ax12_thermal_state_t *t, double ambient_c)
{
    t->winding_c = ambient_c;
    t->case_c = ambient_c;
}

/* Backward Euler, solved exactly (2x2):
 *   Cw (w' - w) / dt = Pw - (w' - c') / Rwc
 *   Cc (c' - c) / dt = Pc + (w' - c') / Rwc - (c' - amb) / Rca */
void ax12_thermal_step(const ax12_thermal_params_t *p, ax12_thermal_state_t *t,
                       double winding_w, double case_w, double ambient_c, double dt_s)
{
    const double aw = dt_s / p->winding_j_c;
    const double ac = dt_s / p->case_j_c;
    const double g_wc = 1.0 / p->winding_case_c_w;
    const double g_ca = 1.0 / p->case_ambient_c_w;

    const double m11 = 1.0 + aw * g_wc;
    const double m12 = -aw * g_wc;
    const double m21 = -ac * g_wc;
    const double m22 = 1.0 + ac * (g_wc + g_ca);
    const double r1 = t->winding_c + aw * winding_w;
    const double r2 = t->case_c + ac * (case_w + g_ca * ambient_c);
    const double det = m11 * m22 - m12 * m21;

    t->winding_c = (r1 * m22 - m12 * r2) / det;
    t->case_c = (m11 * r2 - m21 * r1) / det;
}
