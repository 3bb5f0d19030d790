#include "plant.h"

#include <math.h>
#include <stddef.h>

#define AX12_PI 3.141592653589793
#define AX12_DEG_PER_RAD (180.0 / AX12_PI)
#define AX12_ADC_MAX_MV 5000.0
#define AX12_MAX_SUBSTEPS 100000L

ax12_plant_params_t ax12_plant_params_default(void)
{
    /* Calibration and the reasons for each number: docs/plant.md. */
    ax12_plant_params_t p = {
        .motor = {
            .kt_nm_a = 6.78e-3,
            .r_25c_ohm = 7.0,
            .r_tempco_per_c = 0.00393,
            .i_noload_a = 0.030,
            .inertia_kg_m2 = 1.0e-7,
        },
        .gearbox = {
            .ratio = 254.0,
            .efficiency = 0.76,
            .coulomb_nm = 0.020,
            .static_nm = 0.030,
            .viscous_nm_s_rad = 0.004,
            .inertia_kg_m2 = 1.0e-4,
        },
        .pot = {
            .track_rad = 300.0 / AX12_DEG_PER_RAD,
            .full_scale_mv = 5000.0,
            .dead_band_mv = 0.0,
        },
        .supply = {
            .source_v = 9.6,
            .source_r_ohm = 0.1,
            .standby_a = 0.035,
        },
        .thermal = {
            .winding_j_c = 3.0,
            .case_j_c = 10.0,
            .winding_case_c_w = 3.0,
            .case_ambient_c_w = 18.0,
        },
        .bridge = {
            .on_r_ohm = 0.5,
            .diode_v = 0.8,
        },
        .ambient_c = 25.0,
        .max_substep_s = 250e-6,
    };
    return p;
}

/* The motor loop through one bridge path (bridge.h), linear in the output speed w while that
 * path holds:
 *   winding current   I(w)  = (path_v - ke_out * w) / r_loop
 *   drive at output   D(w)  = N Kt I(w) = d0 - d1 * w */
typedef struct {
    ax12_bridge_path_t path;
    double r_loop_ohm;
    double d0_nm;
    double d1_nm_s;
} loop_t;

/* The loops one duty can take while the winding's resistance and the supply hold (one step):
 * a driven bridge has one; a coasting one is open, or clamped by its body diodes beyond the
 * clamp back-EMF, either way. The supply's standby current sags the voltage the bridge sees. */
typedef struct {
    bool coast;
    double r_winding_ohm;
    double ke_out_v_s;  /* back-EMF per output rad/s: Kt x N */
    double clamp_v;     /* coast: back-EMF beyond which the diodes conduct (driven: 0, unused) */
    loop_t driven_or_open;
    loop_t diodes_ccw;  /* coast, turning CCW beyond the clamp */
    loop_t diodes_cw;
} loops_t;

static void loop_through(const ax12_plant_t *plant, const loops_t *ls, double duty,
                         double supply_v, double emf_v, loop_t *l)
{
    const ax12_plant_params_t *p = &plant->params;
    l->path = ax12_bridge_path(&p->bridge, duty, supply_v, p->supply.source_r_ohm, emf_v);
    l->r_loop_ohm = ls->r_winding_ohm + l->path.r_ohm;
    l->d0_nm = l->path.open ? 0.0 : ls->ke_out_v_s * l->path.path_v / l->r_loop_ohm;
    l->d1_nm_s = l->path.open ? 0.0 : ls->ke_out_v_s * ls->ke_out_v_s / l->r_loop_ohm;
}

static void loops_at(const ax12_plant_t *plant, double duty, loops_t *ls)
{
    const ax12_plant_params_t *p = &plant->params;
    ls->coast = duty == 0.0;
    ls->r_winding_ohm = ax12_motor_resistance_ohm(&p->motor, plant->state.thermal.winding_c);
    ls->ke_out_v_s = p->motor.kt_nm_a * p->gearbox.ratio;
    const double supply_v = ax12_supply_terminal_v(&p->supply, 0.0);
    ls->clamp_v = ls->coast ? ax12_bridge_clamp_v(&p->bridge, supply_v) : 0.0;
    loop_through(plant, ls, duty, supply_v, 0.0, &ls->driven_or_open);
    if (ls->coast) {
        loop_through(plant, ls, duty, supply_v, 2.0 * ls->clamp_v, &ls->diodes_ccw);
        loop_through(plant, ls, duty, supply_v, -2.0 * ls->clamp_v, &ls->diodes_cw);
    }
}

/* The loop at output speed w (as ax12_bridge_path() decides it). */
static const loop_t *loop_at(const loops_t *ls, double speed_rad_s)
{
    const double emf_v = ls->ke_out_v_s * speed_rad_s;
    if (!ls->coast || fabs(emf_v) <= ls->clamp_v) {
        return &ls->driven_or_open;
    }
    return emf_v > 0.0 ? &ls->diodes_ccw : &ls->diodes_cw;
}

static double loop_current_a(const ax12_plant_t *plant, const loop_t *l, double speed_rad_s)
{
    if (l->path.open) {
        return 0.0;
    }
    const ax12_plant_params_t *p = &plant->params;
    return ax12_motor_current_a(&p->motor, l->path.path_v,
                                ax12_gearbox_motor_rad_s(&p->gearbox, speed_rad_s), l->r_loop_ohm);
}

static void update_electrics(ax12_plant_t *plant, const loops_t *ls)
{
    ax12_plant_state_t *s = &plant->state;
    const loop_t *l = loop_at(ls, s->speed_rad_s);
    s->motor_current_a = loop_current_a(plant, l, s->speed_rad_s);
    const double bridge_a = l->path.supply_share * s->motor_current_a;
    s->supply_current_a = ax12_supply_current_a(&plant->params.supply, bridge_a);
    s->terminal_v = ax12_supply_terminal_v(&plant->params.supply, bridge_a);
}

static void refresh(ax12_plant_t *plant)
{
    loops_t ls;
    loops_at(plant, plant->state.duty, &ls);
    update_electrics(plant, &ls);
}

void ax12_plant_init(ax12_plant_t *plant, const ax12_plant_params_t *params)
{
    plant->params = params != NULL ? *params : ax12_plant_params_default();
    plant->load = ax12_load_none();
    plant->state = (ax12_plant_state_t){
        .angle_rad = 150.0 / AX12_DEG_PER_RAD,
        .speed_rad_s = 0.0,
        .stuck = true,
        .duty = 0.0,
    };
    ax12_thermal_init(&plant->state.thermal, plant->params.ambient_c);
    refresh(plant);
}

void ax12_plant_init_on_supply(ax12_plant_t *plant, double source_v, double source_r_ohm)
{
    ax12_plant_params_t p = ax12_plant_params_default();
    p.supply.source_v = source_v;
    p.supply.source_r_ohm = source_r_ohm;
    ax12_plant_init(plant, &p);
}

/* The new speed after h seconds on loop l's path, moving in direction dir: the drive, viscous
 * and load-stiffness terms implicit in the new speed, the friction's sign and the drive's sign
 * taken from the start of the sub-step (body diodes only ever brake). */
static double implicit_speed(const ax12_plant_t *plant, const loop_t *l, double inertia_kg_m2,
                             double coulomb_nm, double load_nm, double k_nm_rad, double dir,
                             double h)
{
    const ax12_gearbox_params_t *g = &plant->params.gearbox;
    const double w = plant->state.speed_rad_s;
    const double drive_nm = l->path.diodes ? -l->path.path_v : l->d0_nm - l->d1_nm_s * w;
    const double drive_sign = drive_nm > 0.0 ? 1.0 : (drive_nm < 0.0 ? -1.0 : 0.0);
    const double kept = ax12_gearbox_drive_share(g, drive_sign, dir);
    const double num = inertia_kg_m2 * w / h + kept * l->d0_nm + load_nm - dir * coulomb_nm;
    const double den = inertia_kg_m2 / h + kept * l->d1_nm_s + g->viscous_nm_s_rad + k_nm_rad * h;
    return num / den;
}

/* One implicit sub-step of the output's motion, h seconds, on the loops ls. Returns the
 * friction heat in J. Coulomb friction with a stuck state: a shaft at rest stays exactly at
 * rest while the net torque is within breakaway friction; a shaft whose speed would change
 * sign stops for the sub-step instead. A coasting bridge's path changes at the speed where
 * the back-EMF reaches its diodes' clamp: the torque balance falls monotonically with the new
 * speed, so the new speed lies on the path it falls on, or exactly at that clamp speed
 * between the two. Stable for any h. */
static double substep(ax12_plant_t *plant, const loops_t *ls, double inertia_kg_m2,
                      double motor_friction_nm, double h)
{
    const ax12_plant_params_t *p = &plant->params;
    const ax12_gearbox_params_t *g = &p->gearbox;
    ax12_plant_state_t *s = &plant->state;
    const double load_nm = ax12_load_torque_nm(&plant->load, s->angle_rad);
    const loop_t *l = loop_at(ls, s->speed_rad_s);
    double dir;

    if (s->stuck) {
        const double net_nm = l->d0_nm + load_nm;
        const double hold_nm = motor_friction_nm + ax12_gearbox_breakaway_friction_nm(g, l->d0_nm);
        if (fabs(net_nm) <= hold_nm) {
            return 0.0;
        }
        dir = net_nm > 0.0 ? 1.0 : -1.0;
    } else {
        dir = s->speed_rad_s > 0.0 ? 1.0 : -1.0;
    }

    const double coulomb_nm = motor_friction_nm + g->coulomb_nm;
    const double k_nm_rad = ax12_load_stiffness_nm_rad(&plant->load, s->angle_rad);
    double w_new = implicit_speed(plant, l, inertia_kg_m2, coulomb_nm, load_nm, k_nm_rad, dir, h);
    if (ls->coast) {
        const double clamp_rad_s = ls->clamp_v / ls->ke_out_v_s;
        const bool beyond = w_new * dir > clamp_rad_s;
        if (beyond != l->path.diodes) {
            const loop_t *other = beyond ? loop_at(ls, w_new) : &ls->driven_or_open;
            const double w_other =
                implicit_speed(plant, other, inertia_kg_m2, coulomb_nm, load_nm, k_nm_rad, dir, h);
            w_new = (w_other * dir > clamp_rad_s) == beyond ? w_other : dir * clamp_rad_s;
        }
    }

    if (w_new * dir <= 0.0) {
        w_new = 0.0;
        s->stuck = true;
    } else {
        s->stuck = false;
    }
    s->speed_rad_s = w_new;
    s->angle_rad += h * w_new;

    const loop_t *after = loop_at(ls, w_new);
    const double friction_nm =
        motor_friction_nm +
        ax12_gearbox_sliding_friction_nm(g, after->d0_nm - after->d1_nm_s * w_new) +
        g->viscous_nm_s_rad * fabs(w_new);
    return friction_nm * fabs(w_new) * h;
}

void ax12_plant_step(ax12_plant_t *plant, double duty, double dt_s)
{
    if (!(dt_s > 0.0)) {
        return;
    }
    if (isnan(duty)) {
        duty = 0.0;
    }
    duty = duty > 1.0 ? 1.0 : (duty < -1.0 ? -1.0 : duty);

    ax12_plant_params_t *p = &plant->params;
    ax12_plant_state_t *s = &plant->state;
    s->duty = duty;

    loops_t ls;
    loops_at(plant, duty, &ls);
    const double inertia_kg_m2 =
        ax12_gearbox_output_inertia_kg_m2(&p->gearbox, p->motor.inertia_kg_m2) +
        ax12_load_inertia_kg_m2(&plant->load);
    const double motor_friction_nm = p->gearbox.ratio * ax12_motor_friction_nm(&p->motor);

    /* sub-steps of at most max_substep_s; beyond AX12_MAX_SUBSTEPS they grow (still stable) */
    const double n_sub = p->max_substep_s > 0.0 ? ceil(dt_s / p->max_substep_s) : 1.0;
    const long n = n_sub < 1.0 ? 1 : (n_sub > AX12_MAX_SUBSTEPS ? AX12_MAX_SUBSTEPS : (long)n_sub);
    const double h = dt_s / (double)n;

    double winding_j = 0.0;
    double case_j = 0.0;
    for (long i = 0; i < n; i++) {
        case_j += substep(plant, &ls, inertia_kg_m2, motor_friction_nm, h);
        const loop_t *l = loop_at(&ls, s->speed_rad_s);
        const double i_a = loop_current_a(plant, l, s->speed_rad_s);
        winding_j += i_a * i_a * ls.r_winding_ohm * h;
        case_j += ax12_bridge_loss_w(&p->bridge, &l->path, i_a) * h;
    }

    update_electrics(plant, &ls);
    case_j += s->terminal_v * p->supply.standby_a * dt_s;
    ax12_thermal_step(&p->thermal, &s->thermal, winding_j / dt_s, case_j / dt_s,
                      p->ambient_c, dt_s);
}

void ax12_plant_set_supply_v(ax12_plant_t *plant, double source_v)
{
    plant->params.supply.source_v = source_v;
    refresh(plant);
}

void ax12_plant_set_ambient_c(ax12_plant_t *plant, double ambient_c)
{
    plant->params.ambient_c = ambient_c;
}

void ax12_plant_set_load(ax12_plant_t *plant, const ax12_load_t *load)
{
    plant->load = *load;
}

void ax12_plant_set_angle_rad(ax12_plant_t *plant, double angle_rad)
{
    plant->state.angle_rad = angle_rad;
    plant->state.speed_rad_s = 0.0;
    plant->state.stuck = true;
    refresh(plant);
}

double ax12_plant_angle_rad(const ax12_plant_t *plant)
{
    return plant->state.angle_rad;
}

double ax12_plant_angle_deg(const ax12_plant_t *plant)
{
    return plant->state.angle_rad * AX12_DEG_PER_RAD;
}

double ax12_plant_speed_rad_s(const ax12_plant_t *plant)
{
    return plant->state.speed_rad_s;
}

double ax12_plant_motor_current_a(const ax12_plant_t *plant)
{
    return plant->state.motor_current_a;
}

double ax12_plant_supply_current_a(const ax12_plant_t *plant)
{
    return plant->state.supply_current_a;
}

double ax12_plant_terminal_v(const ax12_plant_t *plant)
{
    return plant->state.terminal_v;
}

double ax12_plant_winding_temp_c(const ax12_plant_t *plant)
{
    return plant->state.thermal.winding_c;
}

double ax12_plant_case_temp_c(const ax12_plant_t *plant)
{
    return plant->state.thermal.case_c;
}

static double adc_pin_mv(double mv)
{
    return mv < 0.0 ? 0.0 : (mv > AX12_ADC_MAX_MV ? AX12_ADC_MAX_MV : mv);
}

double ax12_plant_pot_mv(const ax12_plant_t *plant)
{
    return adc_pin_mv(ax12_pot_mv(&plant->params.pot, plant->state.angle_rad));
}

double ax12_plant_supply_sense_mv(const ax12_plant_t *plant)
{
    return adc_pin_mv(plant->state.terminal_v * 1000.0 / 5.0);
}

double ax12_plant_temp_sense_mv(const ax12_plant_t *plant)
{
    return adc_pin_mv(500.0 + 10.0 * plant->state.thermal.case_c);
}

/* ---- The shaft driven by a rigid-body engine (plant_joint.h) ---- */

/* duty clamped to -1..+1, NaN as 0 (as ax12_plant_step takes it) */
static double usable_duty(double duty)
{
    return isnan(duty) ? 0.0 : (duty > 1.0 ? 1.0 : (duty < -1.0 ? -1.0 : duty));
}

double ax12_plant_output_drive_nm(const ax12_plant_t *plant, double duty, double speed_rad_s,
                                  double *slope_nm_s_rad)
{
    const ax12_plant_params_t *p = &plant->params;
    loops_t ls;
    loops_at(plant, usable_duty(duty), &ls);
    const loop_t *l = loop_at(&ls, speed_rad_s);
    if (slope_nm_s_rad != NULL) {
        *slope_nm_s_rad = l->d1_nm_s;
    }
    return ax12_gearbox_drive_nm(&p->gearbox,
                                 ax12_motor_torque_nm(&p->motor, loop_current_a(plant, l, speed_rad_s)));
}

double ax12_plant_step_electrics(ax12_plant_t *plant, double duty, double dt_s, double *slope_nm_s_rad)
{
    const ax12_plant_params_t *p = &plant->params;
    ax12_plant_state_t *s = &plant->state;
    s->duty = usable_duty(duty);
    s->stuck = false;
    loops_t ls;
    loops_at(plant, s->duty, &ls);
    const double w = s->speed_rad_s;
    const loop_t *l = loop_at(&ls, w);
    const double i_a = loop_current_a(plant, l, w);
    const double drive_nm = ax12_gearbox_drive_nm(&p->gearbox, ax12_motor_torque_nm(&p->motor, i_a));
    if (slope_nm_s_rad != NULL) {
        *slope_nm_s_rad = l->d1_nm_s;
    }
    if (!(dt_s > 0.0)) {
        return drive_nm;
    }
    update_electrics(plant, &ls);
    /* the friction's heat as the substep's: brush, gear sliding with the drive, viscous */
    const double friction_w = (p->gearbox.ratio * ax12_motor_friction_nm(&p->motor) +
                               ax12_gearbox_sliding_friction_nm(&p->gearbox, drive_nm) +
                               p->gearbox.viscous_nm_s_rad * fabs(w)) * fabs(w);
    const double winding_w = i_a * i_a * ls.r_winding_ohm;
    const double case_w = ax12_bridge_loss_w(&p->bridge, &l->path, i_a) + friction_w + s->terminal_v * p->supply.standby_a;
    ax12_thermal_step(&p->thermal, &s->thermal, winding_w, case_w, p->ambient_c, dt_s);
    return drive_nm;
}
