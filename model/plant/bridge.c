#include "bridge.h"

#include <math.h>

double ax12_bridge_clamp_v(const ax12_bridge_params_t *b, double supply_v)
{
    return supply_v + 2.0 * b->diode_v;
}

ax12_bridge_path_t ax12_bridge_path(const ax12_bridge_params_t *b, double duty, double supply_v,
                                    double source_r_ohm, double emf_v)
{
    if (duty != 0.0) {
        /* the supply delivers duty x I, so its resistance counts duty^2 in the motor loop */
        return (ax12_bridge_path_t){
            .path_v = duty * supply_v,
            .r_ohm = b->on_r_ohm + duty * duty * source_r_ohm,
            .supply_share = duty,
        };
    }
    const double clamp_v = ax12_bridge_clamp_v(b, supply_v);
    if (fabs(emf_v) <= clamp_v) {
        return (ax12_bridge_path_t){.open = true};
    }
    const double sign = emf_v > 0.0 ? 1.0 : -1.0;
    return (ax12_bridge_path_t){
        .diodes = true,
        .path_v = sign * clamp_v,
        .r_ohm = source_r_ohm,
        .supply_share = sign,
        .drop_v = 2.0 * b->diode_v,
    };
}

double ax12_bridge_loss_w(const ax12_bridge_params_t *b, const ax12_bridge_path_t *path,
                          double motor_a)
{
    if (path->open) {
        return 0.0;
    }
    if (path->diodes) {
        return path->drop_v * fabs(motor_a);
    }
    return motor_a * motor_a * b->on_r_ohm;
}
