/* Each plant module alone: bridge, motor, gearbox, load, pot, supply, thermal. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "plant_test_support.h"

static const ax12_plant_params_t *defaults(void)
{
    static ax12_plant_params_t p;
    p = ax12_plant_params_default();
    return &p;
}

/* ---- bridge ---- */

static void driven_bridge_puts_duty_times_supply_across_the_motor(void **state)
{
    (void)state;
    const ax12_bridge_params_t *b = &defaults()->bridge;
    for (double emf = -20.0; emf <= 20.0; emf += 5.0) { /* whatever the back-EMF */
        const ax12_bridge_path_t path = ax12_bridge_path(b, -0.5, 9.6, 0.2, emf);
        assert_false(path.open);
        assert_false(path.diodes);
        assert_near(path.path_v, -4.8, 1e-12);
        assert_near(path.r_ohm, b->on_r_ohm + 0.25 * 0.2, 1e-12);
        assert_near(path.supply_share, -0.5, 0.0);
        assert_near(ax12_bridge_loss_w(b, &path, 2.0), 4.0 * b->on_r_ohm, 1e-12);
    }
}

static void coasting_bridge_is_open_up_to_supply_plus_two_diode_drops(void **state)
{
    (void)state;
    const ax12_bridge_params_t *b = &defaults()->bridge;
    const double clamp_v = 9.6 + 2.0 * b->diode_v;
    assert_near(ax12_bridge_clamp_v(b, 9.6), clamp_v, 1e-12);
    assert_true(b->diode_v >= 0.5 && b->diode_v <= 1.2); /* a MOSFET body diode near 1 A */
    const double emfs[] = {0.0, 5.0, -9.6, 9.6 + b->diode_v, -clamp_v, clamp_v};
    for (size_t i = 0; i < sizeof emfs / sizeof emfs[0]; i++) {
        const ax12_bridge_path_t path = ax12_bridge_path(b, 0.0, 9.6, 0.2, emfs[i]);
        assert_true_msg(path.open, "a back-EMF of %g V makes a current", emfs[i]);
        assert_near(ax12_bridge_loss_w(b, &path, 0.0), 0.0, 0.0);
    }
}

static void coasting_bridge_clamps_a_higher_back_emf_through_its_body_diodes(void **state)
{
    (void)state;
    const ax12_bridge_params_t *b = &defaults()->bridge;
    const double clamp_v = 9.6 + 2.0 * b->diode_v;
    for (double sign = -1.0; sign <= 1.0; sign += 2.0) {
        const ax12_bridge_path_t path = ax12_bridge_path(b, 0.0, 9.6, 0.2, sign * (clamp_v + 0.01));
        assert_false(path.open);
        assert_true(path.diodes);
        assert_near(path.path_v, sign * clamp_v, 1e-12); /* the terminals held at the clamp */
        assert_near(path.r_ohm, 0.2, 0.0);                /* no MOSFET conducts: the source alone */
        assert_near(path.supply_share, sign, 0.0);        /* the whole current goes to the supply */
        assert_near(path.drop_v, 2.0 * b->diode_v, 0.0);
        /* the current opposes the back-EMF: it flows into the supply */
        const double motor_a = (path.path_v - sign * (clamp_v + 1.0)) / (7.0 + path.r_ohm);
        assert_true(motor_a * sign < 0.0);
        assert_true(path.supply_share * motor_a < 0.0);
        assert_near(ax12_bridge_loss_w(b, &path, motor_a), 2.0 * b->diode_v * fabs(motor_a), 1e-12);
    }
}

/* ---- motor ---- */

static void winding_resistance_rises_with_copper_tempco(void **state)
{
    (void)state;
    const ax12_motor_params_t *m = &defaults()->motor;
    assert_near(ax12_motor_resistance_ohm(m, 25.0), m->r_25c_ohm, 1e-12);
    assert_within_pct(ax12_motor_resistance_ohm(m, 125.0), m->r_25c_ohm * 1.393, 0.1);
}

static void motor_current_is_voltage_less_back_emf_over_resistance(void **state)
{
    (void)state;
    const ax12_motor_params_t *m = &defaults()->motor;
    const double w = 500.0;
    assert_near(ax12_motor_backemf_v(m, w), m->kt_nm_a * w, 1e-12);
    assert_near(ax12_motor_current_a(m, 9.0, w, 7.5), (9.0 - m->kt_nm_a * w) / 7.5, 1e-12);
    assert_near(ax12_motor_current_a(m, 0.0, 0.0, 7.5), 0.0, 1e-12);
    assert_near(ax12_motor_torque_nm(m, -1.0), -m->kt_nm_a, 1e-12);
}

static void motor_parameters_are_those_of_a_small_dc_motor(void **state)
{
    (void)state;
    const ax12_motor_params_t *m = &defaults()->motor;
    assert_true(m->r_25c_ohm >= 5.0 && m->r_25c_ohm <= 9.0);
    assert_true(m->kt_nm_a > 2e-3 && m->kt_nm_a < 20e-3);
    assert_true(m->i_noload_a > 0.0 && m->i_noload_a < 0.15);
    /* no-load motor speed at 10 V in the 5000..20000 rpm of such motors */
    const double rpm = 10.0 / m->kt_nm_a * 60.0 / (2.0 * PI);
    assert_true(rpm > 5000.0 && rpm < 20000.0);
}

/* ---- gearbox ---- */

static void gearbox_is_254_to_1(void **state)
{
    (void)state;
    const ax12_gearbox_params_t *g = &defaults()->gearbox;
    assert_near(ax12_gearbox_drive_nm(g, 1e-3), 0.254, 1e-12);
    assert_near(ax12_gearbox_motor_rad_s(g, 1.0), 254.0, 1e-12);
}

static void gear_friction_grows_with_the_torque_carried(void **state)
{
    (void)state;
    const ax12_gearbox_params_t *g = &defaults()->gearbox;
    const double d = 1.0;
    assert_near(ax12_gearbox_sliding_friction_nm(g, d), g->coulomb_nm + (1.0 - g->efficiency) * d,
                1e-12);
    assert_near(ax12_gearbox_sliding_friction_nm(g, -d), ax12_gearbox_sliding_friction_nm(g, d),
                1e-12);
    assert_true(ax12_gearbox_breakaway_friction_nm(g, d) >= ax12_gearbox_sliding_friction_nm(g, d));
    /* what reaches the output while driving: efficiency x drive, less the Coulomb part */
    assert_near(d - ax12_gearbox_sliding_friction_nm(g, d), g->efficiency * d - g->coulomb_nm,
                1e-12);
    assert_true(g->efficiency > 0.5 && g->efficiency < 0.9);
    /* the same friction, seen as the share of the drive kept at the output */
    assert_near(ax12_gearbox_drive_share(g, 1.0, 1.0), g->efficiency, 1e-12);
    assert_near(ax12_gearbox_drive_share(g, -1.0, -1.0), g->efficiency, 1e-12);
    assert_near(ax12_gearbox_drive_share(g, -1.0, 1.0), 2.0 - g->efficiency, 1e-12);
    assert_near(ax12_gearbox_drive_share(g, 0.0, 1.0), 1.0, 1e-12);
}

static void rotor_inertia_dominates_at_the_output(void **state)
{
    (void)state;
    const ax12_plant_params_t *p = defaults();
    const double j = ax12_gearbox_output_inertia_kg_m2(&p->gearbox, p->motor.inertia_kg_m2);
    assert_near(j, p->gearbox.inertia_kg_m2 + 254.0 * 254.0 * p->motor.inertia_kg_m2, 1e-15);
    assert_true(j > 10.0 * p->gearbox.inertia_kg_m2);
}

/* ---- load ---- */

static void no_load_pushes_nothing(void **state)
{
    (void)state;
    const ax12_load_t l = ax12_load_none();
    assert_near(ax12_load_torque_nm(&l, 1.0), 0.0, 0.0);
    assert_near(ax12_load_stiffness_nm_rad(&l, 1.0), 0.0, 0.0);
    assert_near(ax12_load_inertia_kg_m2(&l), 0.0, 0.0);
}

static void constant_load_is_the_same_at_every_angle(void **state)
{
    (void)state;
    const ax12_load_t l = ax12_load_constant(-0.3);
    assert_near(ax12_load_torque_nm(&l, 0.0), -0.3, 0.0);
    assert_near(ax12_load_torque_nm(&l, 4.0), -0.3, 0.0);
}

static void spring_pulls_back_to_its_rest_angle(void **state)
{
    (void)state;
    const ax12_load_t l = ax12_load_spring(2.0, 1.0);
    assert_near(ax12_load_torque_nm(&l, 1.0), 0.0, 1e-15);
    assert_near(ax12_load_torque_nm(&l, 1.5), -1.0, 1e-12);
    assert_near(ax12_load_torque_nm(&l, 0.5), 1.0, 1e-12);
    assert_near(ax12_load_stiffness_nm_rad(&l, 0.0), 2.0, 0.0);
}

static void arm_weighs_most_when_horizontal_and_nothing_when_hanging(void **state)
{
    (void)state;
    const double h = 1.2;
    const ax12_load_t l = ax12_load_arm(0.5, 0.1, h);
    const double mgl = 0.5 * AX12_GRAVITY_M_S2 * 0.1;
    assert_near(ax12_load_torque_nm(&l, h), -mgl, 1e-12);          /* pulls CW, down */
    assert_near(ax12_load_torque_nm(&l, h + PI), mgl, 1e-12);      /* other side: pulls CCW */
    assert_near(ax12_load_torque_nm(&l, h - PI / 2.0), 0.0, 1e-12); /* hanging */
    assert_near(ax12_load_stiffness_nm_rad(&l, h - PI / 2.0), mgl, 1e-12);
    assert_near(ax12_load_stiffness_nm_rad(&l, h + PI / 2.0), 0.0, 0.0); /* upright: unstable */
    assert_near(ax12_load_inertia_kg_m2(&l), 0.5 * 0.01, 1e-15);
}

/* ---- pot ---- */

static void pot_maps_300_degrees_onto_0_to_5000_mv(void **state)
{
    (void)state;
    const ax12_pot_params_t *p = &defaults()->pot;
    assert_near(ax12_pot_mv(p, 0.0), 0.0, 1e-9);
    assert_near(ax12_pot_mv(p, 150.0 * DEG_RAD), 2500.0, 1e-9);
    assert_near(ax12_pot_mv(p, 300.0 * DEG_RAD), 5000.0, 1e-9);
    assert_int_equal(adc_code(ax12_pot_mv(p, 0.0)), 0);
    assert_int_equal(adc_code(ax12_pot_mv(p, 150.0 * DEG_RAD)), 512);
    assert_int_equal(adc_code(ax12_pot_mv(p, 300.0 * DEG_RAD)), 1023);
    double last = -1.0;
    for (int deg10 = 0; deg10 <= 3000; deg10++) {
        const double mv = ax12_pot_mv(p, deg10 * 0.1 * DEG_RAD);
        assert_true(mv >= last);
        last = mv;
    }
}

static void pot_reads_the_pull_down_in_the_dead_band(void **state)
{
    (void)state;
    const ax12_pot_params_t *p = &defaults()->pot;
    assert_false(ax12_pot_in_dead_band(p, 299.9 * DEG_RAD));
    assert_true(ax12_pot_in_dead_band(p, 300.1 * DEG_RAD));
    assert_near(ax12_pot_mv(p, 300.1 * DEG_RAD), 0.0, 0.0);
    assert_near(ax12_pot_mv(p, 330.0 * DEG_RAD), 0.0, 0.0);
    assert_near(ax12_pot_mv(p, 359.9 * DEG_RAD), 0.0, 0.0);
    assert_near(ax12_pot_mv(p, -10.0 * DEG_RAD), 0.0, 0.0); /* = 350 deg */
}

static void pot_wraps_endless_rotation(void **state)
{
    (void)state;
    const ax12_pot_params_t *p = &defaults()->pot;
    assert_near(ax12_pot_mv(p, (360.0 + 150.0) * DEG_RAD), 2500.0, 1e-6);
    assert_near(ax12_pot_mv(p, (-360.0 + 60.0) * DEG_RAD), 1000.0, 1e-6);
}

/* ---- supply ---- */

static void supply_sags_by_its_source_resistance(void **state)
{
    (void)state;
    const ax12_supply_params_t s = {.source_v = 10.0, .source_r_ohm = 0.5, .standby_a = 0.04};
    assert_near(ax12_supply_current_a(&s, 1.0), 1.04, 1e-12);
    assert_near(ax12_supply_terminal_v(&s, 0.0), 10.0 - 0.5 * 0.04, 1e-12);
    assert_near(ax12_supply_terminal_v(&s, 1.0), 10.0 - 0.5 * 1.04, 1e-12);
    assert_near(ax12_supply_terminal_v(&s, -1.0), 10.0 + 0.5 * 0.96, 1e-12); /* regeneration */
}

static void standby_current_is_under_50_ma(void **state)
{
    (void)state;
    const ax12_supply_params_t *s = &defaults()->supply;
    assert_true(s->standby_a > 0.0 && s->standby_a < 0.050);
}

/* ---- thermal ---- */

static void thermal_settles_at_power_times_thermal_resistance(void **state)
{
    (void)state;
    const ax12_thermal_params_t *p = &defaults()->thermal;
    ax12_thermal_state_t t;
    ax12_thermal_init(&t, 20.0);
    for (int i = 0; i < 20000; i++) {
        ax12_thermal_step(p, &t, 2.0, 0.5, 20.0, 1.0);
    }
    const double case_c = 20.0 + 2.5 * p->case_ambient_c_w;
    assert_near(t.case_c, case_c, 1e-6);
    assert_near(t.winding_c, case_c + 2.0 * p->winding_case_c_w, 1e-6);
}

static void thermal_decays_to_ambient_without_power(void **state)
{
    (void)state;
    const ax12_thermal_params_t *p = &defaults()->thermal;
    ax12_thermal_state_t t = {.winding_c = 120.0, .case_c = 90.0};
    double last_j = INFINITY;
    for (int i = 0; i < 3600; i++) {
        ax12_thermal_step(p, &t, 0.0, 0.0, 25.0, 1.0);
        /* heat stored above ambient only ever falls */
        const double stored_j =
            p->winding_j_c * (t.winding_c - 25.0) + p->case_j_c * (t.case_c - 25.0);
        assert_true(stored_j < last_j);
        assert_true(t.winding_c >= t.case_c && t.case_c >= 25.0);
        last_j = stored_j;
    }
    assert_near(t.winding_c, 25.0, 0.1);
    assert_near(t.case_c, 25.0, 0.1);
}

static void thermal_step_is_stable_for_huge_steps(void **state)
{
    (void)state;
    const ax12_thermal_params_t *p = &defaults()->thermal;
    ax12_thermal_state_t t = {.winding_c = 120.0, .case_c = 90.0};
    ax12_thermal_step(p, &t, 0.0, 0.0, 25.0, 1e5);
    assert_near(t.winding_c, 25.0, 0.5);
    assert_near(t.case_c, 25.0, 0.5);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(driven_bridge_puts_duty_times_supply_across_the_motor),
        cmocka_unit_test(coasting_bridge_is_open_up_to_supply_plus_two_diode_drops),
        cmocka_unit_test(coasting_bridge_clamps_a_higher_back_emf_through_its_body_diodes),
        cmocka_unit_test(winding_resistance_rises_with_copper_tempco),
        cmocka_unit_test(motor_current_is_voltage_less_back_emf_over_resistance),
        cmocka_unit_test(motor_parameters_are_those_of_a_small_dc_motor),
        cmocka_unit_test(gearbox_is_254_to_1),
        cmocka_unit_test(gear_friction_grows_with_the_torque_carried),
        cmocka_unit_test(rotor_inertia_dominates_at_the_output),
        cmocka_unit_test(no_load_pushes_nothing),
        cmocka_unit_test(constant_load_is_the_same_at_every_angle),
        cmocka_unit_test(spring_pulls_back_to_its_rest_angle),
        cmocka_unit_test(arm_weighs_most_when_horizontal_and_nothing_when_hanging),
        cmocka_unit_test(pot_maps_300_degrees_onto_0_to_5000_mv),
        cmocka_unit_test(pot_reads_the_pull_down_in_the_dead_band),
        cmocka_unit_test(pot_wraps_endless_rotation),
        cmocka_unit_test(supply_sags_by_its_source_resistance),
        cmocka_unit_test(standby_current_is_under_50_ma),
        cmocka_unit_test(thermal_settles_at_power_times_thermal_resistance),
        cmocka_unit_test(thermal_decays_to_ambient_without_power),
        cmocka_unit_test(thermal_step_is_stable_for_huge_steps),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
