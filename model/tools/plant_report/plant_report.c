/* SPDX-License-Identifier: MIT */
/* ax12-plant-report: open-loop figures of the plant alone (model/plant, no simavr), beside the
 * AX-12 manual (2006); docs/plant.md quotes them.
 * Usage: ax12-plant-report   (no arguments; prints a table on stdout)
 *
 * Spec comparisons use an ideal supply at the connector (source resistance 0);
 * the thermal figures use the default world (9.6 V through 0.1 ohm, 25 degC). */
#include <math.h>
#include <stdio.h>
#include <time.h>

#include "plant.h"

#define KGF_CM_NM 0.0980665
#define PI 3.141592653589793
#define RAD_S_RPM (60.0 / (2.0 * PI))

static ax12_plant_t plant_at(double source_v, double source_r_ohm)
{
    ax12_plant_t plant;
    ax12_plant_init_on_supply(&plant, source_v, source_r_ohm);
    return plant;
}

/* Largest constant opposing load the output still starts to lift from rest at full duty. */
static double stall_torque_nm(double source_v)
{
    double lo = 0.0;
    double hi = 5.0;
    for (int i = 0; i < 40; i++) {
        const double mid = 0.5 * (lo + hi);
        ax12_plant_t plant = plant_at(source_v, 0.0);
        const double start_rad = ax12_plant_angle_rad(&plant);
        const ax12_load_t load = ax12_load_constant(-mid);
        ax12_plant_set_load(&plant, &load);
        for (int k = 0; k < 10; k++) {
            ax12_plant_step(&plant, 1.0, 1e-3);
        }
        if (ax12_plant_angle_rad(&plant) > start_rad) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

static double noload_speed_rad_s(double source_v)
{
    ax12_plant_t plant = plant_at(source_v, 0.0);
    for (int k = 0; k < 2000; k++) {
        ax12_plant_step(&plant, 1.0, 1e-3);
    }
    return ax12_plant_speed_rad_s(&plant);
}

static double noload_current_a(double source_v)
{
    ax12_plant_t plant = plant_at(source_v, 0.0);
    for (int k = 0; k < 2000; k++) {
        ax12_plant_step(&plant, 1.0, 1e-3);
    }
    return ax12_plant_motor_current_a(&plant);
}

/* Time from rest to 63 % of the no-load speed at full duty. */
static double rise_time_s(double source_v)
{
    const double target = (1.0 - exp(-1.0)) * noload_speed_rad_s(source_v);
    ax12_plant_t plant = plant_at(source_v, 0.0);
    double t_s = 0.0;
    while (ax12_plant_speed_rad_s(&plant) < target && t_s < 1.0) {
        ax12_plant_step(&plant, 1.0, 1e-5);
        t_s += 1e-5;
    }
    return t_s;
}

static void clamp_output(ax12_plant_t *plant)
{
    const ax12_load_t clamp = ax12_load_spring(1000.0, ax12_plant_angle_rad(plant));
    ax12_plant_set_load(plant, &clamp);
}

static double stall_current_a(double source_v, double source_r_ohm)
{
    ax12_plant_t plant = plant_at(source_v, source_r_ohm);
    clamp_output(&plant);
    for (int k = 0; k < 10; k++) {
        ax12_plant_step(&plant, 1.0, 1e-3);
    }
    return ax12_plant_motor_current_a(&plant);
}

static double now_s(void)
{
    struct timespec ts;
    timespec_get(&ts, TIME_UTC);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(void)
{
    const double volts[2] = {7.0, 10.0};
    const double spec_kgf_cm[2] = {12.0, 16.5};
    const double spec_s_60deg[2] = {0.269, 0.196};

    printf("AX-12 plant, open loop (ideal supply at the connector, 25 degC)\n\n");
    printf("%-28s %10s %10s %8s\n", "figure", "plant", "manual", "ratio");
    for (int i = 0; i < 2; i++) {
        const double t_nm = stall_torque_nm(volts[i]);
        const double spec_nm = spec_kgf_cm[i] * KGF_CM_NM;
        printf("stall torque %4.1f V  [N*m]  %10.3f %10.3f %8.3f\n", volts[i], t_nm, spec_nm,
               t_nm / spec_nm);
    }
    for (int i = 0; i < 2; i++) {
        const double w = noload_speed_rad_s(volts[i]);
        const double spec_rad_s = (PI / 3.0) / spec_s_60deg[i];
        printf("no-load speed %4.1f V [rpm]  %10.1f %10.1f %8.3f\n", volts[i], w * RAD_S_RPM,
               spec_rad_s * RAD_S_RPM, w / spec_rad_s);
        printf("  as s/60deg                %10.3f %10.3f %8.3f\n", (PI / 3.0) / w,
               spec_s_60deg[i], spec_s_60deg[i] / ((PI / 3.0) / w));
    }
    printf("Moving Speed 1023 [rpm]      %10.1f %10.1f %8.3f   (plant: no-load at 10 V)\n",
           noload_speed_rad_s(10.0) * RAD_S_RPM, 114.0, noload_speed_rad_s(10.0) * RAD_S_RPM / 114.0);
    printf("stall current 7.0 V [A]      %10.3f %10.3f %8.3f   (manual: max current)\n",
           stall_current_a(7.0, 0.0), 0.9, stall_current_a(7.0, 0.0) / 0.9);
    printf("stall current 9.6 V [A]      %10.3f\n", stall_current_a(9.6, 0.0));
    printf("stall current 10.0 V [A]     %10.3f\n", stall_current_a(10.0, 0.0));
    printf("no-load current 10.0 V [A]   %10.3f\n", noload_current_a(10.0));
    printf("time to 63 %% of no-load speed, 9.6 V [ms] %6.1f\n", 1e3 * rise_time_s(9.6));

    ax12_plant_t idle = plant_at(9.6, 0.1);
    ax12_plant_step(&idle, 0.0, 1e-3);
    printf("standby current 9.6 V [A]    %10.3f %10s          (manual: < 50 mA)\n",
           ax12_plant_supply_current_a(&idle), "< 0.050");

    /* The later AX-12A e-manual: 1.5 N*m at 12 V and 1.5 A, 59 rpm. Not calibrated to. */
    printf("\ncross-check, 12 V (AX-12A e-manual, not a target):\n");
    printf("  stall torque [N*m] %7.3f vs 1.5", stall_torque_nm(12.0));
    printf("   stall current [A] %6.3f vs 1.5", stall_current_a(12.0, 0.0));
    printf("   no-load [rpm] %5.1f vs 59\n", noload_speed_rad_s(12.0) * RAD_S_RPM);

    /* Stall at 9.6 V through the default 0.1 ohm, from 25 degC. */
    ax12_plant_t hot = plant_at(9.6, 0.1);
    clamp_output(&hot);
    double t_s = 0.0;
    double winding_85_s = -1.0;
    while (ax12_plant_case_temp_c(&hot) < 85.0 && t_s < 3600.0) {
        ax12_plant_step(&hot, 1.0, 1e-3);
        t_s += 1e-3;
        if (winding_85_s < 0.0 && ax12_plant_winding_temp_c(&hot) >= 85.0) {
            winding_85_s = t_s;
        }
    }
    printf("\nstall at 9.6 V (0.1 ohm source), from 25 degC:\n");
    printf("  winding reaches 85 degC after   %7.1f s\n", winding_85_s);
    printf("  sensor (case) reaches 85 degC   %7.1f s  (winding then %.0f degC, current %.3f A,"
           " terminal %.2f V)\n",
           t_s, ax12_plant_winding_temp_c(&hot), ax12_plant_motor_current_a(&hot),
           ax12_plant_terminal_v(&hot));
    double cool_s = 0.0;
    while (ax12_plant_case_temp_c(&hot) > 35.0 && cool_s < 7200.0) {
        ax12_plant_step(&hot, 0.0, 10e-3);
        cool_s += 10e-3;
    }
    printf("  torque off: sensor back to 35 degC after %.0f s\n", cool_s);

    ax12_plant_t idle_hot = plant_at(9.6, 0.1);
    for (int k = 0; k < 3600; k++) {
        ax12_plant_step(&idle_hot, 0.0, 1.0);
    }
    printf("  idle for 1 h: sensor at %.1f degC (logic heat only)\n",
           ax12_plant_case_temp_c(&idle_hot));

    /* Host cost of one step at 100 us, a servo sweeping back and forth under a spring. */
    ax12_plant_t bench = plant_at(9.6, 0.1);
    const ax12_load_t spring = ax12_load_spring(0.5, 2.6);
    ax12_plant_set_load(&bench, &spring);
    const long steps = 2000000;
    const double t0 = now_s();
    for (long k = 0; k < steps; k++) {
        ax12_plant_step(&bench, (k / 5000) % 2 ? 0.8 : -0.8, 100e-6);
    }
    const double t1 = now_s();
    printf("\nhost cost: %.0f ns per 100 us step (this build)\n", 1e9 * (t1 - t0) / (double)steps);
    return 0;
}
