/* What the MCU's ADC sees, and the power and heat behind it: pot (ADC0),
 * supply sense (ADC1), temperature sensor (ADC2); docs/hardware.md. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "plant_test_support.h"

static void stall(ax12_plant_t *s)
{
    given_load(s, ax12_load_spring(1000.0, ax12_plant_angle_rad(s)));
}

/* ---- pot ---- */

static void pot_reads_0_to_5000_mv_over_0_to_300_degrees(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    const double deg[] = {0.0, 60.0, 150.0, 299.0, 300.0};
    const double mv[] = {0.0, 1000.0, 2500.0, 4983.333, 5000.0};
    for (size_t i = 0; i < sizeof deg / sizeof deg[0]; i++) {
        ax12_plant_set_angle_rad(&s, deg[i] * DEG_RAD);
        assert_near(ax12_plant_pot_mv(&s), mv[i], 0.001);
        assert_near(ax12_plant_angle_deg(&s), deg[i], 1e-9);
    }
}

static void servo_starts_at_the_centre(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    assert_int_equal(adc_code(ax12_plant_pot_mv(&s)), 512);
}

static void pot_reads_0_mv_in_the_dead_band(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    ax12_plant_set_angle_rad(&s, 330.0 * DEG_RAD);
    assert_near(ax12_plant_pot_mv(&s), 0.0, 0.0);
}

static void positive_duty_raises_the_pot_reading(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    const double before = ax12_plant_pot_mv(&s);
    run_for(&s, 0.5, 0.1, 1e-3);
    assert_true(ax12_plant_pot_mv(&s) > before);
    run_for(&s, -0.5, 0.3, 1e-3);
    assert_true(ax12_plant_pot_mv(&s) < before);
}

static void endless_turn_sweeps_the_track_then_the_dead_band(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(10.0, 0.0);
    ax12_plant_set_angle_rad(&s, 0.0);
    int in_dead_band = 0;
    int on_track = 0;
    double last_mv = 0.0;
    while (ax12_plant_angle_rad(&s) < 3.0 * 2.0 * PI) {
        ax12_plant_step(&s, 1.0, 1e-4);
        const double mv = ax12_plant_pot_mv(&s);
        assert_true(mv >= 0.0 && mv <= 5000.0);
        if (mv == 0.0) {
            in_dead_band++;
        } else {
            on_track++;
            if (last_mv != 0.0) {
                assert_true(mv >= last_mv); /* rising while on the track */
            }
        }
        last_mv = mv;
    }
    /* 60 of every 360 degrees read 0 mV (the first turn includes the run-up) */
    const double share = (double)in_dead_band / (double)(in_dead_band + on_track);
    assert_true(share > 0.12 && share < 0.2);
}

/* ---- supply ---- */

static void supply_sense_is_the_terminal_voltage_over_5(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    const double v = 9.6 - 0.1 * s.params.supply.standby_a;
    assert_near(ax12_plant_terminal_v(&s), v, 1e-9);
    assert_near(ax12_plant_supply_sense_mv(&s), v * 200.0, 1e-6);
    ax12_plant_set_supply_v(&s, 12.0);
    assert_near(ax12_plant_supply_sense_mv(&s), (12.0 - 0.1 * s.params.supply.standby_a) * 200.0,
                1e-6);
}

static void supply_sense_clamps_at_the_adc_reference(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(30.0, 0.0);
    assert_near(ax12_plant_supply_sense_mv(&s), 5000.0, 0.0);
}

static void idle_servo_draws_only_its_standby_current(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    run_for(&s, 0.0, 0.1, 1e-3);
    assert_near(ax12_plant_motor_current_a(&s), 0.0, 0.0);
    assert_true(ax12_plant_supply_current_a(&s) > 0.0);
    assert_true(ax12_plant_supply_current_a(&s) < 0.050);
}

static void terminal_voltage_sags_with_stall_current(void **state)
{
    (void)state;
    const double r_src = 0.5;
    ax12_plant_t s = given_servo(9.6, r_src);
    const double idle_v = ax12_plant_terminal_v(&s);
    stall(&s);
    run_for(&s, 1.0, 0.01, 1e-3);
    const double i_a = ax12_plant_supply_current_a(&s);
    assert_true(i_a > 1.0);
    assert_near(i_a, ax12_plant_motor_current_a(&s) + s.params.supply.standby_a, 1e-9);
    assert_near(ax12_plant_terminal_v(&s), 9.6 - r_src * i_a, 1e-9);
    assert_true(ax12_plant_terminal_v(&s) < idle_v - 0.5);
    /* the stall current is what the sagging terminal drives through the loop */
    const ax12_plant_params_t *p = &s.params;
    const double r_loop =
        ax12_motor_resistance_ohm(&p->motor, ax12_plant_winding_temp_c(&s)) + p->bridge.on_r_ohm;
    assert_within_pct(ax12_plant_motor_current_a(&s), ax12_plant_terminal_v(&s) / r_loop, 0.5);
}

static void half_duty_draws_half_the_motor_current_from_the_supply(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    stall(&s);
    run_for(&s, 0.5, 0.01, 1e-3);
    assert_near(ax12_plant_supply_current_a(&s),
                0.5 * ax12_plant_motor_current_a(&s) + s.params.supply.standby_a, 1e-9);
}

static void overhauling_load_returns_current_to_the_supply(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.5);
    given_load(&s, ax12_load_constant(3.0)); /* pushes CCW, faster than duty 0.2 drives */
    run_for(&s, 0.2, 0.5, 1e-3);
    assert_true(ax12_plant_motor_current_a(&s) < 0.0);
    assert_true(ax12_plant_supply_current_a(&s) < 0.0);
    assert_true(ax12_plant_terminal_v(&s) > 9.6);
}

static void back_driven_shaft_with_torque_off_returns_current_past_the_diodes_clamp(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    const ax12_plant_params_t *p = &s.params;
    const double idle_v = 9.6 - 0.1 * p->supply.standby_a;
    const double clamp_rad_s =
        (idle_v + 2.0 * p->bridge.diode_v) / (p->motor.kt_nm_a * p->gearbox.ratio);
    given_load(&s, ax12_load_constant(0.09)); /* turns it, slower than the clamp speed */
    run_for(&s, 0.0, 1.5, 1e-3);
    assert_true(ax12_plant_speed_rad_s(&s) > 1.0 && ax12_plant_speed_rad_s(&s) < clamp_rad_s);
    assert_near(ax12_plant_motor_current_a(&s), 0.0, 0.0);
    assert_near(ax12_plant_terminal_v(&s), idle_v, 1e-12);
    given_load(&s, ax12_load_constant(1.0)); /* faster: the body diodes conduct */
    run_for(&s, 0.0, 0.5, 1e-3);
    assert_true(ax12_plant_speed_rad_s(&s) > clamp_rad_s);
    assert_true(ax12_plant_motor_current_a(&s) < -0.1);
    assert_true(ax12_plant_supply_current_a(&s) < 0.0);
    assert_true(ax12_plant_terminal_v(&s) > idle_v);
    assert_within_pct(ax12_plant_supply_sense_mv(&s), ax12_plant_terminal_v(&s) * 1000.0 / 5.0, 1e-9);
}

/* ---- temperature ---- */

static void temperature_sensor_reads_500_mv_plus_10_mv_per_degree(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    assert_near(ax12_plant_temp_sense_mv(&s), 750.0, 1e-9);
    ax12_plant_params_t p = ax12_plant_params_default();
    p.ambient_c = -5.0;
    ax12_plant_init(&s, &p);
    assert_near(ax12_plant_temp_sense_mv(&s), 450.0, 1e-9);
}

static void stalled_servo_reaches_85_degrees_within_minutes(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    stall(&s);
    double t_s = 0.0;
    while (ax12_plant_case_temp_c(&s) < 85.0 && t_s < 600.0) {
        ax12_plant_step(&s, 1.0, 1e-3);
        t_s += 1e-3;
        assert_true(ax12_plant_winding_temp_c(&s) >= ax12_plant_case_temp_c(&s));
    }
    assert_true_msg(t_s > 30.0 && t_s < 180.0, "85 degC after %.1f s", t_s);
    assert_near(ax12_plant_temp_sense_mv(&s), 500.0 + 850.0, 0.1);
    /* hot copper: the stall current has fallen */
    const double hot_a = ax12_plant_motor_current_a(&s);
    ax12_plant_t cold = given_servo(9.6, 0.1);
    stall(&cold);
    run_for(&cold, 1.0, 0.01, 1e-3);
    assert_true(hot_a < 0.9 * ax12_plant_motor_current_a(&cold));
}

static void hot_servo_cools_to_its_idle_temperature_over_minutes(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    stall(&s);
    run_for(&s, 1.0, 120.0, 1e-2);
    assert_true(ax12_plant_case_temp_c(&s) > 80.0);
    run_for(&s, 0.0, 60.0, 1e-2);
    assert_true_msg(ax12_plant_case_temp_c(&s) > 55.0, "cooled too fast: %.1f degC after 1 min",
                    ax12_plant_case_temp_c(&s));
    run_for(&s, 0.0, 3600.0, 1.0);
    /* idle: only the logic heats the case */
    const ax12_plant_params_t *p = &s.params;
    const double idle_c = p->ambient_c + ax12_plant_terminal_v(&s) * p->supply.standby_a *
                                             p->thermal.case_ambient_c_w;
    assert_near(ax12_plant_case_temp_c(&s), idle_c, 0.2);
    assert_near(ax12_plant_winding_temp_c(&s), idle_c, 0.2);
    assert_true(idle_c - p->ambient_c < 10.0);
}

static void warmer_air_warms_the_idle_servo(void **state)
{
    (void)state;
    ax12_plant_t s = given_servo(9.6, 0.1);
    ax12_plant_set_ambient_c(&s, 45.0);
    run_for(&s, 0.0, 3600.0, 1.0);
    assert_true(ax12_plant_case_temp_c(&s) > 45.0);
    assert_true(ax12_plant_case_temp_c(&s) < 55.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(pot_reads_0_to_5000_mv_over_0_to_300_degrees),
        cmocka_unit_test(servo_starts_at_the_centre),
        cmocka_unit_test(pot_reads_0_mv_in_the_dead_band),
        cmocka_unit_test(positive_duty_raises_the_pot_reading),
        cmocka_unit_test(endless_turn_sweeps_the_track_then_the_dead_band),
        cmocka_unit_test(supply_sense_is_the_terminal_voltage_over_5),
        cmocka_unit_test(supply_sense_clamps_at_the_adc_reference),
        cmocka_unit_test(idle_servo_draws_only_its_standby_current),
        cmocka_unit_test(terminal_voltage_sags_with_stall_current),
        cmocka_unit_test(half_duty_draws_half_the_motor_current_from_the_supply),
        cmocka_unit_test(overhauling_load_returns_current_to_the_supply),
        cmocka_unit_test(back_driven_shaft_with_torque_off_returns_current_past_the_diodes_clamp),
        cmocka_unit_test(temperature_sensor_reads_500_mv_plus_10_mv_per_degree),
        cmocka_unit_test(stalled_servo_reaches_85_degrees_within_minutes),
        cmocka_unit_test(hot_servo_cools_to_its_idle_temperature_over_minutes),
        cmocka_unit_test(warmer_air_warms_the_idle_servo),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
