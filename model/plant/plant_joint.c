#include "plant_joint.h"

#include <math.h>

double ax12_plant_joint_armature_kg_m2(const ax12_plant_t *plant)
{
    const ax12_plant_params_t *p = &plant->params;
    return ax12_gearbox_output_inertia_kg_m2(&p->gearbox, p->motor.inertia_kg_m2);
}

double ax12_plant_joint_frictionloss_nm(const ax12_plant_t *plant, double drive_nm)
{
    const ax12_plant_params_t *p = &plant->params;
    return p->gearbox.ratio * ax12_motor_friction_nm(&p->motor) +
           ax12_gearbox_sliding_friction_nm(&p->gearbox, drive_nm);
}

double ax12_plant_joint_holding_friction_nm(const ax12_plant_t *plant, double drive_nm)
{
    const ax12_plant_params_t *p = &plant->params;
    return p->gearbox.ratio * ax12_motor_friction_nm(&p->motor) +
           ax12_gearbox_breakaway_friction_nm(&p->gearbox, drive_nm);
}

double ax12_plant_joint_viscous_nm_s_rad(const ax12_plant_t *plant)
{
    return plant->params.gearbox.viscous_nm_s_rad;
}

void ax12_plant_joint_step(ax12_plant_t *plant, double duty, double dt_s, ax12_joint_drive_t *acc)
{
    if (!(dt_s > 0.0)) {
        return;
    }
    const double w = plant->state.speed_rad_s;
    double slope;
    const double drive_nm = ax12_plant_step_electrics(plant, duty, dt_s, &slope);
    plant->state.angle_rad += w * dt_s;
    acc->applied_nm_s += (drive_nm + slope * w) * dt_s;
    acc->slope_nm_s2_rad += slope * dt_s;
    acc->span_s += dt_s;
}

static double sign_of(double x)
{
    return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0);
}

ax12_joint_torque_t ax12_plant_joint_take(const ax12_plant_t *plant, ax12_joint_drive_t *acc)
{
    const double w = plant->state.speed_rad_s;
    double applied_nm, slope;
    if (acc->span_s > 0.0) {
        applied_nm = acc->applied_nm_s / acc->span_s;
        slope = acc->slope_nm_s2_rad / acc->span_s;
    } else {
        applied_nm = ax12_plant_output_drive_nm(plant, plant->state.duty, w, &slope) + slope * w;
    }
    *acc = (ax12_joint_drive_t){0};
    const double viscous = ax12_plant_joint_viscous_nm_s_rad(plant);
    if (fabs(w) < AX12_JOINT_AT_REST_RAD_S) {
        return (ax12_joint_torque_t){
            .applied_nm = applied_nm,
            .damping_nm_s_rad = viscous + slope,
            .frictionloss_nm = ax12_plant_joint_holding_friction_nm(plant, applied_nm),
        };
    }
    const double kept = ax12_gearbox_drive_share(&plant->params.gearbox, sign_of(applied_nm - slope * w), sign_of(w));
    return (ax12_joint_torque_t){
        .applied_nm = kept * applied_nm,
        .damping_nm_s_rad = viscous + kept * slope,
        .frictionloss_nm = ax12_plant_joint_frictionloss_nm(plant, 0.0),
    };
}

void ax12_plant_joint_set_motion(ax12_plant_t *plant, double angle_rad, double speed_rad_s)
{
    plant->state.angle_rad = angle_rad;
    plant->state.speed_rad_s = speed_rad_s;
    plant->state.stuck = false;
}
