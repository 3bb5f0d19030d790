/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include <math.h>
#include <stdio.h>
#include <stdbool.h>

#include "elf_symbols.h"
#include "servo_profile.h"

#include "lab_experiments.h"

/* key,value figures for scripts/model_report. */

/* The largest CW load (N m) the servo still turns against from rest at full drive, 1 mN m. */
static double stall_torque(const lab_options_t *o, double supply_v) {
  double lo = 0.5, hi = 2.5;
  while (hi - lo > 0.002) {
    const double mid = 0.5 * (lo + hi);
    const lab_wheel_result_t r = lab_wheel_run(o, supply_v, mid, 1023);
    if (r.plant_rpm > 0.05 && r.protocol_rpm > 0.0) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return lo;
}

/* Joint mode cruise at Moving Speed `units` from 100 to 900: mean Present Speed and shaft rpm
 * over the middle of the travel. */
static void cruise(const lab_options_t *o, double supply_v, uint16_t units, double *present_units, double *plant_rpm) {
  lab_t lab;
  ax12_plant_t plant = lab_plant(o, supply_v, 0.0);
  ax12_plant_set_angle_rad(&plant, 100.0 * 300.0 / 1024.0 / LAB_DEG_PER_RAD);
  lab_open(&lab, o, &plant);
  lab_write_u16(&lab, CT_ADDR_MOVING_SPEED, units);
  lab_write_u16(&lab, CT_ADDR_GOAL_POSITION, 100);
  lab_write_u8(&lab, CT_ADDR_TORQUE_ENABLE, 1);
  lab_run_ms(&lab, 50.0);
  lab_write_u16(&lab, CT_ADDR_GOAL_POSITION, 900);
  double sum = 0.0, a0 = 0.0, t0 = 0.0;
  int n = 0;
  for (int i = 0; i < 3000; i++) {
    lab_run_ms(&lab, 5.0);
    const lab_present_t p = lab_read_present(&lab);
    if (p.position >= 350 && p.position <= 650) {
      if (n == 0) {
        a0 = ax12_plant_angle_rad(&lab.servo->plant);
        t0 = lab_now_ms(&lab);
      }
      sum += p.speed;
      n++;
    } else if (p.position > 650) {
      break;
    }
  }
  *present_units = n ? sum / n : 0.0;
  *plant_rpm = n ? (ax12_plant_angle_rad(&lab.servo->plant) - a0) / ((lab_now_ms(&lab) - t0) / 1000.0) * LAB_RPM_PER_RAD_S : 0.0;
  lab_close(&lab);
}

/* Current at stall: full drive against a stiff spring (the shaft barely moves). Returns the
 * supply current (motor + logic); *motor_a the motor's. */
static double stall_current(const lab_options_t *o, double supply_v, double *motor_a) {
  lab_t lab;
  const ax12_plant_t plant = lab_plant(o, supply_v, 0.0);
  lab_open(&lab, o, &plant);
  lab_write_u16(&lab, CT_ADDR_GOAL_POSITION, 1000);
  lab_write_u8(&lab, CT_ADDR_TORQUE_ENABLE, 1);
  lab_set_load(&lab, ax12_load_spring(50.0, 150.0 / LAB_DEG_PER_RAD));
  lab_run_ms(&lab, 500.0);
  const double a = ax12_plant_supply_current_a(&lab.servo->plant);
  *motor_a = ax12_plant_motor_current_a(&lab.servo->plant);
  lab_close(&lab);
  return a;
}

int lab_report(const lab_options_t *o) {
  printf("key,value\n");
  for (int v = 0; v < 2; v++) {
    const double volts = v == 0 ? 7.0 : 10.0;
    const lab_wheel_result_t r = lab_wheel_run(o, volts, 0.0, 1023);
    printf("noload_rpm_plant_%.0fv,%.3f\n", volts, r.plant_rpm);
    printf("noload_rpm_protocol_%.0fv,%.3f\n", volts, r.protocol_rpm);
    printf("noload_present_speed_%.0fv,%.1f\n", volts, r.present_speed);
    printf("noload_current_%.0fv,%.4f\n", volts, r.current_a);
    printf("stall_torque_%.0fv,%.4f\n", volts, stall_torque(o, volts));
    double motor_a;
    printf("stall_current_%.0fv,%.4f\n", volts, stall_current(o, volts, &motor_a));
    printf("stall_motor_current_%.0fv,%.4f\n", volts, motor_a);
    fflush(stdout);
  }
  static const uint16_t speeds[] = {50, 100, 200, 300, 400};
  for (size_t i = 0; i < sizeof(speeds) / sizeof(speeds[0]); i++) {
    double units, rpm;
    cruise(o, 10.0, speeds[i], &units, &rpm);
    printf("cruise_%u_present_speed,%.1f\n", speeds[i], units);
    printf("cruise_%u_plant_rpm,%.3f\n", speeds[i], rpm);
  }
  /* Standby: torque off, at rest. */
  {
    lab_t lab;
    const ax12_plant_t plant = lab_plant(o, 9.6, 0.0);
    lab_open(&lab, o, &plant);
    lab_run_ms(&lab, 100.0);
    printf("standby_current,%.4f\n", ax12_plant_supply_current_a(&lab.servo->plant));
    lab_close(&lab);
  }
  /* The control tick, measured on the MCU: from the entry of the Timer1 COMPB ISR (the 1 kHz
   * tick, tiny_isr.S) until the core sleeps again, i.e. the ISR plus the main loop's tick work
   * (ADC, control_tick, LED, packet finder poll). Over 2 s of joint-mode moves; first with
   * the bus idle, then with the master reading Present* every 2 ms (packet work that falls
   * inside a tick's busy time counts too). */
  uint32_t entry;
  if (!elf_symbol_address(o->elf, "__vector_12", &entry)) {
    lab_die("no __vector_12 (TIMER1_COMPB) in %s", o->elf);
  }
  for (int polled = 0; polled < 2; polled++) {
    lab_t lab;
    const ax12_plant_t plant = lab_plant(o, 9.6, 0.0);
    lab_open(&lab, o, &plant);
    lab_write_u8(&lab, CT_ADDR_TORQUE_ENABLE, 1);
    lab_write_u16(&lab, CT_ADDR_GOAL_POSITION, 900);
    lab_run_ms(&lab, 1.0);
    servo_set_probe(lab.servo, entry);
    const double t0 = lab_now_ms(&lab);
    bool back = false;
    while (lab_now_ms(&lab) - t0 < 2000.0) {
      if (polled) {
        (void)lab_read_present(&lab);
      }
      lab_run_ms(&lab, 2.0);
      if (!back && lab_now_ms(&lab) - t0 > 1000.0) {
        if (!polled) { /* the bus-idle figure leaves this packet's work out */
          lab.servo->probe_pc = 0;
          lab.servo->probe_inside = false;
        }
        lab_write_u16(&lab, CT_ADDR_GOAL_POSITION, 100);
        lab.servo->probe_pc = entry;
        back = true;
      }
    }
    const servo_t *s = lab.servo;
    const char *tag = polled ? "polled" : "idle";
    printf("tick_calls_%s,%llu\n", tag, (unsigned long long)s->probe_calls);
    printf("tick_cycles_max_%s,%llu\n", tag, (unsigned long long)s->probe_max_cycles);
    printf("tick_cycles_mean_%s,%.1f\n", tag,
           s->probe_calls ? (double)s->probe_total_cycles / (double)s->probe_calls : 0.0);
    lab_close(&lab);
  }
  return 0;
}

