/* The output as a joint of a rigid-body engine (plant_joint.h): the joint's terms, given to a
 * stand-in for the engine (one implicit Euler step a millisecond, as MuJoCo integrates a hinge
 * with armature, damping and frictionloss), move a shaft as the plant's own mechanics do, so
 * the gearbox's inertia and friction are counted once; coasting and holding as the plant does. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "plant_joint.h"
#include "plant_test_support.h"

#define ENGINE_STEP_S 0.001
#define PLANT_STEP_S 0.0001

typedef struct {
    double angle_rad, speed_rad_s; /* the joint's */
} joint_t;

/* One engine step of the joint under t and an external torque load_nm: implicit in the
 * damping, Coulomb friction up to frictionloss. */
static void engine_step(joint_t *j, double armature, const ax12_joint_torque_t *t, double load_nm)
{
    const double h = ENGINE_STEP_S;
    const double den = armature + h * t->damping_nm_s_rad;
    const double free_w = (armature * j->speed_rad_s + h * (t->applied_nm + load_nm)) / den;
    const double friction_w = h * t->frictionloss_nm / den;
    j->speed_rad_s = fabs(free_w) <= friction_w ? 0.0 : free_w - copysign(friction_w, free_w);
    j->angle_rad += h * j->speed_rad_s;
}

/* seconds of duty: the plant stepped every 100 us on the joint, the engine every 1 ms. */
static void run_on_joint(ax12_plant_t *plant, joint_t *j, double duty, double load_nm, double seconds)
{
    const double armature = ax12_plant_joint_armature_kg_m2(plant);
    ax12_joint_drive_t acc = {0};
    const long steps = (long)(seconds / ENGINE_STEP_S + 0.5);
    for (long k = 0; k < steps; k++) {
        for (int i = 0; i < 10; i++) {
            ax12_plant_joint_step(plant, duty, PLANT_STEP_S, &acc);
        }
        const ax12_joint_torque_t t = ax12_plant_joint_take(plant, &acc);
        engine_step(j, armature, &t, load_nm);
        ax12_plant_joint_set_motion(plant, j->angle_rad, j->speed_rad_s);
    }
}

static void the_armature_is_the_gearbox_and_the_rotor_through_the_ratio(void **state)
{
    (void)state;
    ax12_plant_t plant = given_servo(9.6, 0.1);
    const ax12_plant_params_t *p = &plant.params;
    assert_near(ax12_plant_joint_armature_kg_m2(&plant),
                p->gearbox.inertia_kg_m2 + p->gearbox.ratio * p->gearbox.ratio * p->motor.inertia_kg_m2, 1e-12);
    assert_near(ax12_plant_joint_armature_kg_m2(&plant), 6.55e-3, 1e-5);
}

static void a_free_joint_speeds_up_as_the_plants_own_shaft(void **state)
{
    (void)state;
    ax12_plant_t own = given_servo(9.6, 0.1);
    ax12_plant_t on_joint = given_servo(9.6, 0.1);
    joint_t j = {.angle_rad = ax12_plant_angle_rad(&on_joint)};
    /* the engine's 1 ms implicit steps lag the plant's 250 us substeps by about a step while the
     * shaft speeds up (time constant 17 ms), less and less */
    const double checkpoints_s[] = {0.01, 0.02, 0.05, 0.3};
    const double within_pct[] = {2.5, 1.5, 0.8, 0.1};
    double elapsed = 0.0;
    for (size_t i = 0; i < 4; i++) {
        run_for(&own, 1.0, checkpoints_s[i] - elapsed, PLANT_STEP_S);
        run_on_joint(&on_joint, &j, 1.0, 0.0, checkpoints_s[i] - elapsed);
        elapsed = checkpoints_s[i];
        assert_within_pct(j.speed_rad_s, ax12_plant_speed_rad_s(&own), within_pct[i]);
    }
    assert_within_pct(ax12_plant_motor_current_a(&on_joint), ax12_plant_motor_current_a(&own), 0.5);
    /* at no-load speed (counted twice, the friction would show as a lower speed) */
    assert_within_pct(ax12_plant_winding_temp_c(&on_joint), ax12_plant_winding_temp_c(&own), 0.5);
}

static void a_coasting_joint_has_only_the_gearbox_friction(void **state)
{
    (void)state;
    ax12_plant_t plant = given_servo(9.6, 0.1);
    ax12_joint_drive_t acc = {0};
    ax12_plant_joint_set_motion(&plant, 1.0, 2.0);
    ax12_plant_joint_step(&plant, 0.0, PLANT_STEP_S, &acc);
    assert_near(ax12_plant_angle_rad(&plant), 1.0 + 2.0 * PLANT_STEP_S, 1e-12); /* the pot advances at its speed */
    const ax12_joint_torque_t t = ax12_plant_joint_take(&plant, &acc);
    assert_near(t.applied_nm, 0.0, 1e-12);
    assert_near(t.damping_nm_s_rad, plant.params.gearbox.viscous_nm_s_rad, 1e-12);
    assert_near(t.frictionloss_nm, 0.052 + 0.020, 0.001); /* turning: brush through the ratio, gear Coulomb */
    ax12_plant_joint_set_motion(&plant, 1.0, 0.0);
    ax12_plant_joint_step(&plant, 0.0, PLANT_STEP_S, &acc);
    const ax12_joint_torque_t at_rest = ax12_plant_joint_take(&plant, &acc);
    assert_near(at_rest.frictionloss_nm, 0.052 + 0.030, 0.001); /* at rest: the breakaway friction */
    assert_near(ax12_plant_motor_current_a(&plant), 0.0, 1e-12);
    assert_near(ax12_plant_angle_rad(&plant), 1.0, 1e-12); /* the pot follows the joint */
}

static void the_gears_hold_on_a_joint_what_they_hold_on_the_plant(void **state)
{
    (void)state;
    /* a load the motor cannot lift at full duty but the gears hold (docs/plant.md): still */
    for (int own = 0; own < 2; own++) {
        ax12_plant_t plant = given_servo(10.0, 0.0);
        const double load_nm = -2.2;
        joint_t j = {.angle_rad = ax12_plant_angle_rad(&plant)};
        if (own) {
            given_load(&plant, ax12_load_constant(load_nm));
            run_for(&plant, 1.0, 0.5, PLANT_STEP_S);
            assert_near(ax12_plant_speed_rad_s(&plant), 0.0, 1e-9);
        } else {
            run_on_joint(&plant, &j, 1.0, load_nm, 0.5);
            assert_near(j.speed_rad_s, 0.0, 1e-9);
        }
    }
    /* and one above what they hold sinks on both */
    ax12_plant_t plant = given_servo(10.0, 0.0);
    joint_t j = {.angle_rad = ax12_plant_angle_rad(&plant)};
    run_on_joint(&plant, &j, 1.0, -3.2, 0.2);
    assert_true(j.speed_rad_s < -0.1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(the_armature_is_the_gearbox_and_the_rotor_through_the_ratio),
        cmocka_unit_test(a_free_joint_speeds_up_as_the_plants_own_shaft),
        cmocka_unit_test(a_coasting_joint_has_only_the_gearbox_friction),
        cmocka_unit_test(the_gears_hold_on_a_joint_what_they_hold_on_the_plant),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
