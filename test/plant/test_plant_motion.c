/* The whole servo in motion, open loop: torque, speed, friction, loads,
 * energy and the integrator. Spec figures: AX-12 manual (2006), page 3. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "plant_test_support.h"

#define STALL_7V_NM (12.0 * KGF_CM_NM)
#define STALL_10V_NM (16.5 * KGF_CM_NM)
#define NOLOAD_7V_RAD_S ((PI / 3.0) / 0.269)
#define NOLOAD_10V_RAD_S ((PI / 3.0) / 0.196)

/* From rest at full duty against a constant opposing load: does the output rise? */
static int lifts(double source_v, double load_nm)
{
    ax12_plant_t s = given_servo(source_v, 0.0);
    given_load(&s, ax12_load_constant(-load_nm));
    const double start_rad = ax12_plant_angle_rad(&s);
    run_for(&s, 1.0, 0.2, 1e-3);
    return ax12_plant_angle_rad(&s) > start_rad;
}

static double steady_speed_rad_s(double source_v, double duty)
{
    ax12_plant_t s = given_servo(source_v, 0.0);
    run_for(&s, duty, 1.5, 1e-3);
    return ax12_plant_speed_rad_s(&s);
}

static double mechanical_energy_j(const ax12_plant_t *s, double k_nm_rad, double rest_rad)
{
    const ax12_plant_params_t *p = &s->params;
    const double j = ax12_gearbox_output_inertia_kg_m2(&p->gearbox, p->motor.inertia_kg_m2);
    const double w = ax12_plant_speed_rad_s(s);
    const double x = ax12_plant_angle_rad(s) - rest_rad;
    return 0.5 * j * w * w + 0.5 * k_nm_rad * x * x;
}

/* Friction that holds a shaft at rest with the terminals open, at the output. */
static double coast_breakaway_nm(const ax12_plant_t *s)
{
    const ax12_plant_params_t *p = &s->params;
    return p->gearbox.static_nm + p->gearbox.ratio * ax12_motor_friction_nm(&p->motor);
}

/* Steady speed of a coasting servo back-driven by a constant load_nm beyond its friction, from
 * bridge.h: the back-EMF held at supply + 2 diode drops, the excess through winding and source;
 * load = (2 - efficiency) x braking drive + Coulomb + viscous. */
static double coasting_steady_speed_rad_s(const ax12_plant_t *s, double load_nm)
{
    const ax12_plant_params_t *p = &s->params;
    const double supply_v = p->supply.source_v - p->supply.source_r_ohm * p->supply.standby_a;
    const double clamp_v = supply_v + 2.0 * p->bridge.diode_v;
    const double kt_out = p->motor.kt_nm_a * p->gearbox.ratio;
    const double r_loop = ax12_motor_resistance_ohm(&p->motor, ax12_plant_winding_temp_c(s)) +
                          p->supply.source_r_ohm;
    const double d0 = kt_out * clamp_v / r_loop;
    const double d1 = kt_out * kt_out / r_loop;
    const double share = 2.0 - p->gearbox.efficiency;
    const double coulomb_nm =
        p->gearbox.coulomb_nm + p->gearbox.ratio * ax12_motor_friction_nm(&p->motor);
    const double sign = load_nm > 0.0 ? 1.0 : -1.0;
    return sign * (share * d0 + fabs(load_nm) - coulomb_nm) / (share * d1 + p->gearbox.viscous_nm_s_rad);
}

/* ---- the manual's figures ---- */

static void stall_torque_at_7v_is_12_kgf_cm_within_5_pct(void **state)
{
    (void)state;
    assert_true_msg(lifts(7.0, 0.95 * STALL_7V_NM), "cannot lift 95 %% of 12 kgf*cm at 7 V");
    assert_true_msg(!lifts(7.0, 1.05 * STALL_7V_NM), "lifts 105 %% of 12 kgf*cm at 7 V");
}

static void stall_torque_at_10v_is_16_5_kgf_cm_within_5_pct(void **state)
{
    (void)state;
    assert_true_msg(lifts(10.0, 0.95 * STALL_10V_NM), "cannot lift 95 %% of 16.5 kgf*cm at 10 V");
    assert_true_msg(!lifts(10.0, 1.05 * STALL_10V_NM), "lifts 105 %% of 16.5 kgf*cm at 10 V");
}

static void noload_speed_at_7v_is_0_269_s_per_60_deg_within_5_pct(void **state)
{
    (void)state;
    assert_within_pct(steady_speed_rad_s(7.0, 1.0), NOLOAD_7V_RAD_S, 5.0);
}

static void noload_speed_at_10v_is_0_196_s_per_60_deg_within_5_pct(void **state)
{
    (void)state;
    assert_within_pct(steady_speed_rad_s(10.0, 1.0), NOLOAD_10V_RAD_S, 5.0);
}

static void stall_current_at_7v_is_near_the_900_ma_maximum(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(7.0, 0.0);
    given_load(&s, ax12_load_spring(1000.0, ax12_plant_angle_rad(&s)));
    run_for(&s, 1.0, 0.01, 1e-3);
    assert_within_pct(ax12_plant_motor_current_a(&s), 0.900, 5.0);
}

/* ---- speed against voltage and duty ---- */

static void steady_speed_is_affine_in_voltage_with_a_small_friction_offset(void **state)
{
    (void)state;
    const double w4 = steady_speed_rad_s(4.0, 1.0);
    const double w6 = steady_speed_rad_s(6.0, 1.0);
    const double w8 = steady_speed_rad_s(8.0, 1.0);
    const double w10 = steady_speed_rad_s(10.0, 1.0);
    /* equal steps for equal volts */
    assert_within_pct(w6 - w4, w8 - w6, 1.0);
    assert_within_pct(w10 - w8, w8 - w6, 1.0);
    /* the line meets zero speed between 0 and 1 V: friction, not a dead zone */
    const double v0 = 4.0 - w4 / ((w10 - w4) / 6.0);
    assert_true_msg(v0 > 0.0 && v0 < 1.0, "zero-speed intercept %.3f V", v0);
}

static void half_duty_at_10v_runs_like_full_duty_at_5v(void **state)
{
    (void)state;
    assert_within_pct(steady_speed_rad_s(10.0, 0.5), steady_speed_rad_s(5.0, 1.0), 0.1);
}

static void negative_duty_runs_clockwise_at_the_same_speed(void **state)
{
    (void)state;
    const double ccw = steady_speed_rad_s(9.6, 0.7);
    assert_true(ccw > 0.0);
    assert_within_pct(steady_speed_rad_s(9.6, -0.7), -ccw, 0.01);
}

static void duty_beyond_full_is_full(void **state)
{
    (void)state;
    assert_within_pct(steady_speed_rad_s(9.6, 3.0), steady_speed_rad_s(9.6, 1.0), 1e-9);
    assert_within_pct(steady_speed_rad_s(9.6, -3.0), steady_speed_rad_s(9.6, -1.0), 1e-9);
}

/* ---- friction and coasting ---- */

static void coasting_output_slows_to_rest_through_friction(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(10.0, 0.0);
    run_for(&s, 1.0, 0.5, 1e-3);
    double last = ax12_plant_speed_rad_s(&s);
    assert_true(last > 4.0);
    for (int i = 0; i < 2000 && ax12_plant_speed_rad_s(&s) != 0.0; i++) {
        ax12_plant_step(&s, 0.0, 1e-3);
        assert_near(ax12_plant_motor_current_a(&s), 0.0, 0.0); /* terminals open */
        assert_true(ax12_plant_speed_rad_s(&s) >= 0.0);
        assert_true(ax12_plant_speed_rad_s(&s) < last);
        last = ax12_plant_speed_rad_s(&s);
    }
    assert_near(ax12_plant_speed_rad_s(&s), 0.0, 0.0);
    const double rest_rad = ax12_plant_angle_rad(&s);
    run_for(&s, 0.0, 1.0, 1e-3);
    assert_near(ax12_plant_angle_rad(&s), rest_rad, 0.0); /* stays put: no creep, no chatter */
}

static void driven_output_does_not_start_below_breakaway(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.0);
    const double start_rad = ax12_plant_angle_rad(&s);
    run_for(&s, 0.01, 1.0, 1e-3); /* 96 mV: too little to overcome the brushes and gears */
    assert_near(ax12_plant_angle_rad(&s), start_rad, 0.0);
    run_for(&s, 0.08, 1.0, 1e-3);
    assert_true(ax12_plant_angle_rad(&s) > start_rad);
}

static void load_between_sliding_and_breakaway_friction_holds_still_but_keeps_motion(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    const ax12_plant_params_t *p = &s.params;
    const double sliding_nm =
        p->gearbox.coulomb_nm + p->gearbox.ratio * ax12_motor_friction_nm(&p->motor);
    const double load_nm = 0.5 * (sliding_nm + coast_breakaway_nm(&s));
    given_load(&s, ax12_load_constant(load_nm));
    const double start_rad = ax12_plant_angle_rad(&s);
    run_for(&s, 0.0, 1.0, 1e-3);
    assert_near(ax12_plant_angle_rad(&s), start_rad, 0.0);
    run_for(&s, 1.0, 0.02, 1e-3); /* a nudge the way the load pulls */
    run_for(&s, 0.0, 8.0, 1e-3);
    /* sliding: the load's excess over sliding friction balances viscous friction */
    assert_true(coast_breakaway_nm(&s) - sliding_nm > 0.005);
    assert_within_pct(ax12_plant_speed_rad_s(&s), (load_nm - sliding_nm) / p->gearbox.viscous_nm_s_rad,
                      5.0);
}

static void back_driving_a_powered_servo_fights_gear_friction_too(void **state)
{
    (void)state;
    const double load_nm = 3.5; /* CW, more than the servo holds at 10 V */
    ax12_plant_t s = given_servo(10.0, 0.0);
    given_load(&s, ax12_load_constant(-load_nm));
    run_for(&s, 1.0, 1.0, 1e-3);
    /* steady: load = (2 - efficiency) x drive + Coulomb + viscous, drive = d0 - d1 w */
    const ax12_plant_params_t *p = &s.params;
    const double kt_out = p->motor.kt_nm_a * p->gearbox.ratio;
    const double r_loop =
        ax12_motor_resistance_ohm(&p->motor, ax12_plant_winding_temp_c(&s)) + p->bridge.on_r_ohm;
    const double d0 = kt_out * 10.0 / r_loop;
    const double d1 = kt_out * kt_out / r_loop;
    const double share = 2.0 - p->gearbox.efficiency;
    const double coulomb_nm =
        p->gearbox.coulomb_nm + p->gearbox.ratio * ax12_motor_friction_nm(&p->motor);
    const double w = (share * d0 - load_nm + coulomb_nm) / (share * d1 + p->gearbox.viscous_nm_s_rad);
    assert_true(w < -0.5);
    assert_within_pct(ax12_plant_speed_rad_s(&s), w, 2.0);
}

static void coasting_servo_under_a_load_brakes_through_its_body_diodes(void **state)
{
    (void)state;
    const double loads_nm[] = {1.0, -3.0, 0.3};
    for (size_t i = 0; i < sizeof loads_nm / sizeof loads_nm[0]; i++) {
        ax12_plant_t s = given_servo(9.6, 0.1);
        const ax12_plant_params_t *p = &s.params;
        given_load(&s, ax12_load_constant(loads_nm[i]));
        run_for(&s, 0.0, 3.0, 1e-3);
        const double w = ax12_plant_speed_rad_s(&s);
        assert_within_pct(w, coasting_steady_speed_rad_s(&s, loads_nm[i]), 1.0);
        /* the motor returns current to the supply: the terminal rises above its idle voltage */
        const double i_a = ax12_plant_motor_current_a(&s);
        assert_true(i_a * w < 0.0);
        assert_true(ax12_plant_supply_current_a(&s) < p->supply.standby_a);
        assert_true(ax12_plant_terminal_v(&s) >
                    p->supply.source_v - p->supply.source_r_ohm * p->supply.standby_a);
        /* power: what the back-EMF gives = what reaches the connector + diodes + winding (the
         * winding's resistance as of the step's start: 0.01 %) */
        const double emf_v = p->motor.kt_nm_a * p->gearbox.ratio * w;
        const double r_w = ax12_motor_resistance_ohm(&p->motor, ax12_plant_winding_temp_c(&s));
        assert_within_pct(fabs(emf_v * i_a),
                          fabs(i_a) * (ax12_plant_terminal_v(&s) + 2.0 * p->bridge.diode_v) +
                              i_a * i_a * r_w,
                          0.01);
    }
}

static void coasting_servo_below_the_clamp_speed_draws_no_current(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    const ax12_plant_params_t *p = &s.params;
    const double clamp_rad_s =
        (9.6 - 0.1 * p->supply.standby_a + 2.0 * p->bridge.diode_v) /
        (p->motor.kt_nm_a * p->gearbox.ratio);
    /* a load that turns it just below the clamp speed on friction alone */
    const double coulomb_nm =
        p->gearbox.coulomb_nm + p->gearbox.ratio * ax12_motor_friction_nm(&p->motor);
    given_load(&s, ax12_load_constant(-(coulomb_nm + 0.9 * clamp_rad_s * p->gearbox.viscous_nm_s_rad)));
    run_for(&s, 0.0, 20.0, 1e-3);
    assert_within_pct(ax12_plant_speed_rad_s(&s), -0.9 * clamp_rad_s, 1.0);
    assert_near(ax12_plant_motor_current_a(&s), 0.0, 0.0);
    assert_near(ax12_plant_supply_current_a(&s), p->supply.standby_a, 1e-12);
}

static void coasting_heavy_arm_falls_no_faster_than_its_diodes_allow(void **state)
{
    (void)state;
    const double horizontal = 150.0 * DEG_RAD;
    const double mgl = 2.0 * AX12_GRAVITY_M_S2 * 0.1;
    ax12_plant_t s = given_servo(9.6, 0.1);
    given_load(&s, ax12_load_arm(2.0, 0.1, horizontal));
    ax12_plant_set_angle_rad(&s, horizontal + PI / 2.0 - 0.05); /* nearly straight up */
    /* no faster than the steady speed under the arm's largest torque */
    const double bound_rad_s = fabs(coasting_steady_speed_rad_s(&s, -mgl));
    double fastest = 0.0;
    for (int i = 0; i < 10000; i++) {
        ax12_plant_step(&s, 0.0, 1e-3);
        fastest = fmax(fastest, fabs(ax12_plant_speed_rad_s(&s)));
    }
    assert_true(fastest > 0.5 * bound_rad_s);
    assert_true_msg(fastest <= bound_rad_s, "%.3f rad/s, above %.3f", fastest, bound_rad_s);
    assert_near(ax12_plant_speed_rad_s(&s), 0.0, 0.0);
    assert_near(ax12_plant_angle_rad(&s), horizontal - PI / 2.0,
                asin(coast_breakaway_nm(&s) / mgl) + 1e-6);
}

static void output_gains_no_speed_with_duty_zero(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    run_for(&s, -1.0, 0.3, 1e-4);
    double last = fabs(ax12_plant_speed_rad_s(&s));
    for (int i = 0; i < 20000; i++) {
        ax12_plant_step(&s, 0.0, 1e-4);
        const double now = fabs(ax12_plant_speed_rad_s(&s));
        assert_true(now <= last);
        last = now;
    }
}

static void mechanical_energy_only_falls_with_duty_zero_on_a_spring(void **state)
{
    (void)state;
    const double k = 0.5;
    const double rest = 150.0 * DEG_RAD;
    ax12_plant_t s = given_servo(9.6, 0.1);
    given_load(&s, ax12_load_spring(k, rest));
    ax12_plant_set_angle_rad(&s, rest + 1.5);
    double last = mechanical_energy_j(&s, k, rest);
    for (int i = 0; i < 50000; i++) {
        ax12_plant_step(&s, 0.0, 1e-4);
        const double now = mechanical_energy_j(&s, k, rest);
        assert_true_msg(now <= last + 1e-15, "energy rose from %.9g to %.9g J at step %d", last,
                        now, i);
        last = now;
    }
}

/* ---- loads ---- */

static void unpowered_spring_settles_within_the_friction_band_of_rest(void **state)
{
    (void)state;
    const double k = 5.0;
    const double rest = 150.0 * DEG_RAD;
    ax12_plant_t s = given_servo(9.6, 0.1);
    given_load(&s, ax12_load_spring(k, rest));
    ax12_plant_set_angle_rad(&s, rest + 0.8);
    run_for(&s, 0.0, 10.0, 1e-3);
    assert_near(ax12_plant_speed_rad_s(&s), 0.0, 0.0);
    assert_near(ax12_plant_angle_rad(&s), rest, coast_breakaway_nm(&s) / k);
}

static void driven_spring_settles_where_the_drive_meets_the_spring(void **state)
{
    (void)state;
    const double k = 2.0;
    const double rest = 150.0 * DEG_RAD;
    const double duty = 0.5;
    ax12_plant_t s = given_servo(10.0, 0.0);
    given_load(&s, ax12_load_spring(k, rest));
    ax12_plant_set_angle_rad(&s, rest);
    run_for(&s, duty, 3.0, 1e-3);
    /* what reaches the output at zero speed: efficiency x stall drive, less Coulomb friction */
    const ax12_plant_params_t *p = &s.params;
    const double kt_out = p->motor.kt_nm_a * p->gearbox.ratio;
    const double r_loop = ax12_motor_resistance_ohm(&p->motor, ax12_plant_winding_temp_c(&s)) +
                          p->bridge.on_r_ohm;
    const double drive_nm = kt_out * duty * 10.0 / r_loop;
    const double out_nm = p->gearbox.efficiency * drive_nm - p->gearbox.coulomb_nm -
                          p->gearbox.ratio * ax12_motor_friction_nm(&p->motor);
    assert_within_pct(ax12_plant_angle_rad(&s) - rest, out_nm / k, 1.0);
    assert_true(ax12_plant_angle_rad(&s) - rest > 10.0 * DEG_RAD);
}

static void unpowered_heavy_arm_falls_and_rests_hanging(void **state)
{
    (void)state;
    const double horizontal = 150.0 * DEG_RAD;
    const double mgl = 1.0 * AX12_GRAVITY_M_S2 * 0.1;
    ax12_plant_t s = given_servo(9.6, 0.1);
    given_load(&s, ax12_load_arm(1.0, 0.1, horizontal));
    ax12_plant_set_angle_rad(&s, horizontal);
    run_for(&s, 0.0, 20.0, 1e-3);
    assert_near(ax12_plant_speed_rad_s(&s), 0.0, 0.0);
    assert_near(ax12_plant_angle_rad(&s), horizontal - PI / 2.0,
                asin(coast_breakaway_nm(&s) / mgl) + 1e-6);
}

static void gear_friction_holds_a_light_arm_with_torque_off(void **state)
{
    (void)state;
    const double horizontal = 150.0 * DEG_RAD;
    ax12_plant_t s = given_servo(9.6, 0.1);
    given_load(&s, ax12_load_arm(0.05, 0.1, horizontal)); /* 0.049 N*m */
    assert_true(0.05 * AX12_GRAVITY_M_S2 * 0.1 < coast_breakaway_nm(&s));
    ax12_plant_set_angle_rad(&s, horizontal);
    run_for(&s, 0.0, 5.0, 1e-3);
    assert_near(ax12_plant_angle_rad(&s), horizontal, 0.0);
}

static void powered_servo_lifts_an_arm_from_hanging_past_horizontal(void **state)
{
    (void)state;
    const double horizontal = 150.0 * DEG_RAD;
    ax12_plant_t s = given_servo(10.0, 0.1);
    given_load(&s, ax12_load_arm(0.5, 0.15, horizontal)); /* 0.74 N*m at horizontal */
    ax12_plant_set_angle_rad(&s, horizontal - PI / 2.0);
    run_for(&s, 1.0, 1.0, 1e-3);
    assert_true(ax12_plant_angle_rad(&s) > horizontal);
}

static void gears_hold_an_arm_the_motor_cannot_lift(void **state)
{
    (void)state;
    const double horizontal = 150.0 * DEG_RAD;
    ax12_plant_t s = given_servo(10.0, 0.0);
    given_load(&s, ax12_load_arm(2.0, 0.1, horizontal)); /* 1.96 N*m: more than stall */
    ax12_plant_set_angle_rad(&s, horizontal);
    run_for(&s, 1.0, 2.0, 1e-3);
    assert_near(ax12_plant_angle_rad(&s), horizontal, 0.0);
    run_for(&s, 0.0, 0.5, 1e-3); /* torque off: it falls */
    assert_true(ax12_plant_angle_rad(&s) < horizontal - 10.0 * DEG_RAD);
}

/* ---- the integrator ---- */

typedef struct {
    double angle_rad[200];
    double speed_rad_s[200];
} trace_t;

/* A busy second and a half: full CCW, braking reverse, coast, gentle CCW, on a spring. */
static void run_profile(double dt_s, trace_t *out)
{
    ax12_plant_t s = given_servo(9.6, 0.1);
    given_load(&s, ax12_load_spring(1.0, 150.0 * DEG_RAD));
    const long per_sample = (long)(0.01 / dt_s + 0.5);
    for (int k = 0; k < 150; k++) {
        const double t = k * 0.01;
        const double duty = t < 0.3 ? 1.0 : t < 0.6 ? -0.6 : t < 1.0 ? 0.0 : 0.3;
        for (long i = 0; i < per_sample; i++) {
            ax12_plant_step(&s, duty, dt_s);
        }
        out->angle_rad[k] = ax12_plant_angle_rad(&s);
        out->speed_rad_s[k] = ax12_plant_speed_rad_s(&s);
    }
}

static void steps_of_1_ms_agree_with_steps_of_100_us(void **state)
{
    (void)state;
    static trace_t fine;
    static trace_t coarse;
    run_profile(1e-4, &fine);
    run_profile(1e-3, &coarse);
    double max_speed = 0.0;
    for (int k = 0; k < 150; k++) {
        max_speed = fmax(max_speed, fabs(fine.speed_rad_s[k]));
    }
    assert_true(max_speed > 3.0);
    for (int k = 0; k < 150; k++) {
        assert_near(coarse.angle_rad[k], fine.angle_rad[k], 0.2 * DEG_RAD);
        assert_near(coarse.speed_rad_s[k], fine.speed_rad_s[k], 0.02 * max_speed);
    }
}

static void large_steps_stay_bounded(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    given_load(&s, ax12_load_spring(50.0, 150.0 * DEG_RAD));
    for (int i = 0; i < 200; i++) {
        ax12_plant_step(&s, (i / 20) % 2 ? 1.0 : -1.0, 50e-3);
        assert_true(isfinite(ax12_plant_angle_rad(&s)));
        assert_true(fabs(ax12_plant_speed_rad_s(&s)) < 1.2 * NOLOAD_10V_RAD_S);
        assert_true(fabs(ax12_plant_angle_rad(&s) - 150.0 * DEG_RAD) < 0.2);
    }
}

static void one_long_step_lands_where_many_short_ones_do(void **state)
{
    (void)state;
    ax12_plant_t one = given_servo(9.6, 0.1);
    ax12_plant_t many = given_servo(9.6, 0.1);
    given_load(&one, ax12_load_spring(1.0, 150.0 * DEG_RAD));
    given_load(&many, ax12_load_spring(1.0, 150.0 * DEG_RAD));
    ax12_plant_step(&one, 0.5, 2.0);
    run_for(&many, 0.5, 2.0, 1e-4);
    assert_near(ax12_plant_angle_rad(&one), ax12_plant_angle_rad(&many), 0.2 * DEG_RAD);
    assert_near(ax12_plant_winding_temp_c(&one), ax12_plant_winding_temp_c(&many), 0.2);
}

static void zero_or_negative_step_changes_nothing(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    run_for(&s, 1.0, 0.1, 1e-3);
    const ax12_plant_state_t before = s.state;
    ax12_plant_step(&s, -1.0, 0.0);
    ax12_plant_step(&s, -1.0, -1e-3);
    ax12_plant_step(&s, -1.0, NAN);
    assert_near(s.state.angle_rad, before.angle_rad, 0.0);
    assert_near(s.state.speed_rad_s, before.speed_rad_s, 0.0);
    assert_near(s.state.duty, before.duty, 0.0);
    assert_near(s.state.motor_current_a, before.motor_current_a, 0.0);
    assert_near(s.state.thermal.winding_c, before.thermal.winding_c, 0.0);
}

static void nan_duty_coasts(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    run_for(&s, 1.0, 0.1, 1e-3);
    ax12_plant_step(&s, NAN, 1e-3);
    assert_near(ax12_plant_motor_current_a(&s), 0.0, 0.0);
    assert_true(isfinite(ax12_plant_speed_rad_s(&s)));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(stall_torque_at_7v_is_12_kgf_cm_within_5_pct),
        cmocka_unit_test(stall_torque_at_10v_is_16_5_kgf_cm_within_5_pct),
        cmocka_unit_test(noload_speed_at_7v_is_0_269_s_per_60_deg_within_5_pct),
        cmocka_unit_test(noload_speed_at_10v_is_0_196_s_per_60_deg_within_5_pct),
        cmocka_unit_test(stall_current_at_7v_is_near_the_900_ma_maximum),
        cmocka_unit_test(steady_speed_is_affine_in_voltage_with_a_small_friction_offset),
        cmocka_unit_test(half_duty_at_10v_runs_like_full_duty_at_5v),
        cmocka_unit_test(negative_duty_runs_clockwise_at_the_same_speed),
        cmocka_unit_test(duty_beyond_full_is_full),
        cmocka_unit_test(coasting_output_slows_to_rest_through_friction),
        cmocka_unit_test(driven_output_does_not_start_below_breakaway),
        cmocka_unit_test(load_between_sliding_and_breakaway_friction_holds_still_but_keeps_motion),
        cmocka_unit_test(back_driving_a_powered_servo_fights_gear_friction_too),
        cmocka_unit_test(output_gains_no_speed_with_duty_zero),
        cmocka_unit_test(mechanical_energy_only_falls_with_duty_zero_on_a_spring),
        cmocka_unit_test(unpowered_spring_settles_within_the_friction_band_of_rest),
        cmocka_unit_test(driven_spring_settles_where_the_drive_meets_the_spring),
        cmocka_unit_test(unpowered_heavy_arm_falls_and_rests_hanging),
        cmocka_unit_test(gear_friction_holds_a_light_arm_with_torque_off),
        cmocka_unit_test(powered_servo_lifts_an_arm_from_hanging_past_horizontal),
        cmocka_unit_test(gears_hold_an_arm_the_motor_cannot_lift),
        cmocka_unit_test(steps_of_1_ms_agree_with_steps_of_100_us),
        cmocka_unit_test(large_steps_stay_bounded),
        cmocka_unit_test(one_long_step_lands_where_many_short_ones_do),
        cmocka_unit_test(zero_or_negative_step_changes_nothing),
        cmocka_unit_test(nan_duty_coasts),
        cmocka_unit_test(coasting_servo_under_a_load_brakes_through_its_body_diodes),
        cmocka_unit_test(coasting_servo_below_the_clamp_speed_draws_no_current),
        cmocka_unit_test(coasting_heavy_arm_falls_no_faster_than_its_diodes_allow),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
