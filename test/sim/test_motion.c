/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The servo itself: the firmware ELF in simavr driving the plant (model/plant), seen only
 * through the protocol (and the LED pin PB5). Goal moves and Moving, steady-state error,
 * compliance slopes 17 and 32 alike, wheel mode both ways, a torque-off servo back-driven by a
 * load, every alarm (trip, LED blink, shutdown, recovery) in both profiles. All bounded by simulated time (docs/control.md). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <avr_ioport.h>
#include <avr_timer.h>
#include <sim_avr.h>
#include <sim_io.h>

#include "dxl_protocol.h"
#include "dxl_table.h"
#include "plant_options.h"
#include "sim_harness.h"

/* main.c shows control_led_on() after the power-up blink (docs/control.md): set by the build
 * when firmware/app/main.c calls it; until then the alarm blink cannot reach PB5. */
#ifndef AX12_FIRMWARE_SHOWS_ALARM_LED
#define AX12_FIRMWARE_SHOWS_ALARM_LED 0
#endif

typedef struct {
  harness_t h;
  servo_t *servo;
  const char *profile;
  uint8_t last_error; /* error byte of the last status packet */
} rig_t;

static void rig_open(rig_t *r, const char *profile, const plant_options_t *world) {
  memset(r, 0, sizeof(*r));
  r->profile = profile;
  harness_open(&r->h, profile, "atmega88", 1);
  r->servo = harness_add_servo(&r->h, 1, 1, NULL);
  plant_options_t defaults;
  plant_options_default(&defaults);
  ax12_plant_t plant;
  plant_options_build(world ? world : &defaults, &plant);
  servo_attach_plant(r->servo, &plant);
  harness_boot(&r->h, 500); /* past the power-up blink (4 x 100 ms) */
}

static void rig_close(rig_t *r) { harness_close(&r->h); }

static bool is_ax12a(const rig_t *r) { return strcmp(r->profile, "ax12a") == 0; }

static void run_ms(rig_t *r, unsigned ms) { world_run_until(r->h.world, r->h.world->now + sim_ms(ms)); }

static void write_bytes(rig_t *r, uint8_t addr, const uint8_t *data, size_t n) {
  uint8_t params[16] = {addr};
  memcpy(params + 1, data, n);
  uint8_t reply[64];
  const size_t got = harness_request(&r->h, 1, DXL_INST_WRITE, params, n + 1u, 6u, reply);
  assert_int_equal(got, 6u);
  r->last_error = reply[4];
}

static void write_u8(rig_t *r, uint8_t addr, uint8_t v) { write_bytes(r, addr, &v, 1); }

static void write_u16(rig_t *r, uint8_t addr, uint16_t v) {
  const uint8_t d[2] = {(uint8_t)(v & 0xFFu), (uint8_t)(v >> 8)};
  write_bytes(r, addr, d, 2);
}

static uint16_t read_n(rig_t *r, uint8_t addr, uint8_t n) {
  uint8_t reply[64];
  const size_t got = harness_request(&r->h, 1, DXL_INST_READ, HP(addr, n), 6u + n, reply);
  assert_int_equal(got, 6u + n);
  r->last_error = reply[4];
  return n == 1 ? reply[5] : (uint16_t)(reply[5] | (reply[6] << 8));
}

static uint8_t read_u8(rig_t *r, uint8_t addr) { return (uint8_t)read_n(r, addr, 1); }
static uint16_t read_u16(rig_t *r, uint8_t addr) { return read_n(r, addr, 2); }

/* Error byte of a PING reply: the conditions that hold now. */
static uint8_t ping_error(rig_t *r) {
  uint8_t reply[64];
  const size_t got = harness_request(&r->h, 1, DXL_INST_PING, H_NO_PARAMS, 6u, reply);
  assert_int_equal(got, 6u);
  return reply[4];
}

static int signed_register(uint16_t v) { return (v & 0x400u) ? -(int)(v & 0x3FFu) : (int)(v & 0x3FFu); }

/* Timer0's clock select (TCCR0B, data address 0x45 on the ATmega88/328P): the firmware runs
 * the PWM timer only while the motor is driven (firmware/hal/motor.c). */
static bool pwm_timer_running(const rig_t *r) { return (r->servo->avr->data[0x45] & 0x07u) != 0; }

/* Polls Moving every 5 ms until it reads 0; returns the simulated ms it took (fails past limit_ms). */
static unsigned wait_until_still(rig_t *r, unsigned limit_ms) {
  for (unsigned t = 0; t <= limit_ms; t += 5) {
    if (read_u8(r, CT_ADDR_MOVING) == 0) {
      return t;
    }
    run_ms(r, 5);
  }
  fail_msg("Moving still 1 after %u ms", limit_ms);
  return 0;
}

static uint64_t led_transitions_during(rig_t *r, unsigned ms) {
  const uint64_t before = r->servo->board.led_transitions;
  run_ms(r, ms);
  return r->servo->board.led_transitions - before;
}

/* ---- motion ---- */

static void goal_move(const char *profile) {
  rig_t r;
  rig_open(&r, profile, NULL);
  const uint16_t start = read_u16(&r, CT_ADDR_PRESENT_POSITION);
  assert_in_range(start, 510, 514);
  assert_false(pwm_timer_running(&r)); /* torque off: coasting */
  write_u8(&r, CT_ADDR_TORQUE_ENABLE, 1);
  write_u16(&r, CT_ADDR_GOAL_POSITION, 700);
  run_ms(&r, 20);
  assert_int_equal(read_u8(&r, CT_ADDR_MOVING), 1);
  assert_true(pwm_timer_running(&r));
  assert_true(board_pwm_duty(&r.servo->board) > 0.0);
  assert_true(read_u16(&r, CT_ADDR_PRESENT_POSITION) > start);
  const unsigned took = wait_until_still(&r, 2000);
  run_ms(&r, 200);
  const int position = read_u16(&r, CT_ADDR_PRESENT_POSITION);
  const int margin = read_u8(&r, CT_ADDR_CCW_COMPLIANCE_MARGIN);
  /* Steady state: within the margin plus the arrival tolerance (2 counts) plus one count of
   * static friction below the punch (docs/control.md). */
  assert_in_range(position, 700 - margin - 3, 700 + margin + 3);
  assert_int_equal(read_u8(&r, CT_ADDR_MOVING), 0);
  /* The shaft is where the pot says (1024 counts per 300 deg). */
  const double shaft_counts = ax12_plant_angle_deg(&r.servo->plant) * 1024.0 / 300.0;
  assert_true(fabs(shaft_counts - position) < 1.5);
  /* About 55 deg at up to ~50 rpm: a few hundred ms. */
  assert_in_range(took, 100, 1000);
  /* And back, CW. */
  write_u16(&r, CT_ADDR_GOAL_POSITION, 300);
  (void)wait_until_still(&r, 3000);
  run_ms(&r, 200);
  const int back = read_u16(&r, CT_ADDR_PRESENT_POSITION);
  assert_in_range(back, 300 - read_u8(&r, CT_ADDR_CW_COMPLIANCE_MARGIN) - 3, 300 + read_u8(&r, CT_ADDR_CW_COMPLIANCE_MARGIN) + 3);
  rig_close(&r);
}

static void test_goal_moves_output_ax12(void **state) {
  (void)state;
  goal_move("ax12");
}

static void test_goal_moves_output_ax12a(void **state) {
  (void)state;
  goal_move("ax12a");
}

/* Moving Speed limits the cruise: Present Speed near the register (0.111 rpm per unit). */
static void test_moving_speed_cruise(void **state) {
  (void)state;
  rig_t r;
  rig_open(&r, "ax12", NULL);
  write_u8(&r, CT_ADDR_TORQUE_ENABLE, 1);
  write_u16(&r, CT_ADDR_MOVING_SPEED, 200);
  write_u16(&r, CT_ADDR_GOAL_POSITION, 900);
  run_ms(&r, 300);
  /* Present Speed is a filtered pot difference (docs/control.md): a few % of noise. */
  int sum = 0;
  for (int i = 0; i < 10; i++) {
    sum += signed_register(read_u16(&r, CT_ADDR_PRESENT_SPEED));
    run_ms(&r, 20);
  }
  assert_in_range(sum / 10, 190, 210);
  const double rpm = ax12_plant_speed_rad_s(&r.servo->plant) * 60.0 / (2.0 * M_PI);
  assert_true(fabs(rpm - 200 * 0.111) < 0.05 * 200 * 0.111);
  rig_close(&r);
}

/* The trajectory of Present Position after a goal step, sampled every 4 ms. */
static void step_trajectory(uint8_t slope, uint16_t *out, size_t n) {
  rig_t r;
  rig_open(&r, "ax12", NULL);
  write_u8(&r, CT_ADDR_CW_COMPLIANCE_SLOPE, slope);
  write_u8(&r, CT_ADDR_CCW_COMPLIANCE_SLOPE, slope);
  write_u8(&r, CT_ADDR_TORQUE_ENABLE, 1);
  write_u16(&r, CT_ADDR_GOAL_POSITION, 612);
  for (size_t i = 0; i < n; i++) {
    out[i] = read_u16(&r, CT_ADDR_PRESENT_POSITION);
    run_ms(&r, 4);
  }
  rig_close(&r);
}

static void test_slopes_17_and_32_identical(void **state) {
  (void)state;
  enum { N = 150 };
  uint16_t a[N], b[N], c[N];
  step_trajectory(17, a, N);
  step_trajectory(32, b, N);
  step_trajectory(64, c, N);
  assert_memory_equal(a, b, sizeof(a));
  assert_true(memcmp(a, c, sizeof(a)) != 0); /* the next power of two does differ */
  assert_in_range(a[N - 1], 605, 619);
}

static void test_wheel_mode_both_directions(void **state) {
  (void)state;
  rig_t r;
  rig_open(&r, "ax12", NULL);
  write_u16(&r, CT_ADDR_CW_ANGLE_LIMIT, 0);
  write_u16(&r, CT_ADDR_CCW_ANGLE_LIMIT, 0);
  write_u8(&r, CT_ADDR_TORQUE_ENABLE, 1);
  write_u16(&r, CT_ADDR_MOVING_SPEED, 1023); /* CCW, full */
  run_ms(&r, 150);
  const uint16_t p0 = read_u16(&r, CT_ADDR_PRESENT_POSITION);
  run_ms(&r, 100);
  const uint16_t p1 = read_u16(&r, CT_ADDR_PRESENT_POSITION);
  const uint16_t ccw = read_u16(&r, CT_ADDR_PRESENT_SPEED);
  assert_true(p1 > p0 + 50); /* ~50 rpm = 300 deg/s: ~100 counts in 100 ms */
  assert_int_equal(ccw & 0x400u, 0);
  assert_true((ccw & 0x3FFu) > 300);
  assert_int_equal(signed_register(read_u16(&r, CT_ADDR_PRESENT_LOAD)), 1023);
  assert_int_equal(read_u8(&r, CT_ADDR_MOVING), 1);

  write_u16(&r, CT_ADDR_MOVING_SPEED, 0x400u | 1023u); /* CW, full */
  run_ms(&r, 200);
  const uint16_t q0 = read_u16(&r, CT_ADDR_PRESENT_POSITION);
  run_ms(&r, 100);
  const uint16_t q1 = read_u16(&r, CT_ADDR_PRESENT_POSITION);
  const uint16_t cw = read_u16(&r, CT_ADDR_PRESENT_SPEED);
  assert_true(q1 + 50 < q0);
  assert_int_equal(cw & 0x400u, 0x400u);
  assert_true((cw & 0x3FFu) > 300);
  assert_int_equal(signed_register(read_u16(&r, CT_ADDR_PRESENT_LOAD)), -1023);

  write_u16(&r, CT_ADDR_MOVING_SPEED, 0); /* coasts to a stop on friction */
  run_ms(&r, 1000);
  assert_int_equal(read_u8(&r, CT_ADDR_MOVING), 0);
  assert_int_equal(read_u16(&r, CT_ADDR_PRESENT_SPEED) & 0x3FFu, 0);
  rig_close(&r);
}

/* ---- torque off under a load ---- */

/* Steady output speed of a coasting servo back-driven by a constant load_nm beyond friction
 * (model/plant/bridge.h): the back-EMF above supply + 2 body-diode drops drives current back
 * into the supply through winding and source; load = (2 - efficiency) x braking drive +
 * Coulomb + viscous (docs/plant.md). */
static double coasting_speed_rad_s(const ax12_plant_t *plant, double load_nm) {
  const ax12_plant_params_t *p = &plant->params;
  const double clamp_v = p->supply.source_v - p->supply.source_r_ohm * p->supply.standby_a + 2.0 * p->bridge.diode_v;
  const double kt_out = p->motor.kt_nm_a * p->gearbox.ratio;
  const double r_loop =
      ax12_motor_resistance_ohm(&p->motor, ax12_plant_winding_temp_c(plant)) + p->supply.source_r_ohm;
  const double share = 2.0 - p->gearbox.efficiency;
  const double coulomb_nm = p->gearbox.coulomb_nm + p->gearbox.ratio * ax12_motor_friction_nm(&p->motor);
  const double sign = load_nm > 0.0 ? 1.0 : -1.0;
  return sign * (share * kt_out * clamp_v / r_loop + fabs(load_nm) - coulomb_nm) /
         (share * kt_out * kt_out / r_loop + p->gearbox.viscous_nm_s_rad);
}

/* docs/dashboard.md's `world --servo 2 --load-torque -3` on a servo whose torque is off: the
 * firmware leaves the bridge coasting (Timer0 stopped, both inputs low) and the output, dragged
 * CW, turns at the steady speed the body diodes' braking allows, returning current to the
 * supply; Present Position wraps over the pot's track as the shaft turns. Open terminals
 * would let it spin at (3 - friction) / viscous = 730 rad/s: tens of thousands of degrees a
 * second. */
static void test_torque_off_under_a_constant_load_turns_at_the_body_diodes_braking_speed(void **state) {
  (void)state;
  rig_t r;
  rig_open(&r, "ax12", NULL);
  const ax12_load_t load = ax12_load_constant(-3.0);
  ax12_plant_set_load(&r.servo->plant, &load);
  const double start_deg = ax12_plant_angle_deg(&r.servo->plant);
  run_ms(&r, 1000);
  const double first_second_deg = ax12_plant_angle_deg(&r.servo->plant) - start_deg;
  assert_int_equal(read_u8(&r, CT_ADDR_TORQUE_ENABLE), 0);
  assert_false(pwm_timer_running(&r));
  assert_true(board_pwm_duty(&r.servo->board) == 0.0);
  uint16_t lowest = 1023;
  uint16_t highest = 0;
  for (int i = 0; i < 100; i++) { /* a second of Present Position, every 10 ms */
    const uint16_t position = read_u16(&r, CT_ADDR_PRESENT_POSITION);
    lowest = position < lowest ? position : lowest;
    highest = position > highest ? position : highest;
    run_ms(&r, 8);
  }
  const ax12_plant_t *plant = &r.servo->plant;
  const double w = ax12_plant_speed_rad_s(plant);
  const double expected = coasting_speed_rad_s(plant, -3.0);
  assert_true(fabs(w - expected) <= 0.02 * fabs(expected));
  assert_true(expected < -10.0 && expected > -15.0); /* 95-145 rpm: a few turns a second */
  assert_true(first_second_deg < 0.0 && first_second_deg > -1.1 * fabs(expected) * 180.0 / M_PI);
  assert_true(ax12_plant_motor_current_a(plant) > 0.3);             /* CCW current: it brakes */
  assert_true(ax12_plant_supply_current_a(plant) < 0.0);            /* into the supply */
  assert_true(ax12_plant_terminal_v(plant) > plant->params.supply.source_v);
  assert_true(lowest < 100 && highest > 900); /* a turn a second: the pot's whole track */
  print_message("torque off under -3 N m: %.2f rad/s (%.0f rpm; the model's %.2f), %.0f deg in the first second, "
                "%.2f A into the supply\n",
                w, w * 60.0 / (2.0 * M_PI), expected, first_second_deg, -ax12_plant_supply_current_a(plant));
  rig_close(&r);
}

/* A heavy arm released near upright with torque off: it falls no faster than the diodes'
 * braking allows under its largest torque, swings, and comes to rest hanging. */
static void test_torque_off_a_heavy_arm_falls_braked_and_rests_hanging(void **state) {
  (void)state;
  plant_options_t world;
  plant_options_default(&world);
  const double horizontal_rad = 150.0 * M_PI / 180.0;
  world.load = ax12_load_arm(2.0, 0.1, horizontal_rad);
  rig_t r;
  rig_open(&r, "ax12", &world);
  ax12_plant_set_angle_rad(&r.servo->plant, horizontal_rad + M_PI / 2.0 - 0.05); /* nearly up */
  const double mgl = 2.0 * AX12_GRAVITY_M_S2 * 0.1;
  const double bound = fabs(coasting_speed_rad_s(&r.servo->plant, -mgl));
  double fastest = 0.0;
  for (int ms = 0; ms < 6000; ms++) {
    run_ms(&r, 1);
    fastest = fmax(fastest, fabs(ax12_plant_speed_rad_s(&r.servo->plant)));
  }
  assert_true(fastest > 0.5 * bound && fastest <= bound);
  assert_true(ax12_plant_speed_rad_s(&r.servo->plant) == 0.0);
  const double hanging_deg = (horizontal_rad - M_PI / 2.0) * 180.0 / M_PI;
  assert_true(fabs(ax12_plant_angle_deg(&r.servo->plant) - hanging_deg) < 5.0);
  print_message("arm of 2 kg at 0.1 m, torque off: fastest %.2f rad/s (bound %.2f), rests at %.1f deg (hanging %.0f)\n",
                fastest, bound, ax12_plant_angle_deg(&r.servo->plant), hanging_deg);
  rig_close(&r);
}

/* ---- alarms ---- */

/* After a trip: torque off, the error bit in replies, Torque Limit 0 in ax12a, the LED blinks. */
static void expect_tripped(rig_t *r, uint8_t bit) {
  assert_int_equal(read_u8(r, CT_ADDR_TORQUE_ENABLE), 0);
  assert_true((ping_error(r) & bit) != 0);
  if (is_ax12a(r)) {
    assert_int_equal(read_u16(r, CT_ADDR_TORQUE_LIMIT), 0);
  } else {
    assert_int_not_equal(read_u16(r, CT_ADDR_TORQUE_LIMIT), 0);
  }
  const uint64_t blinks = led_transitions_during(r, 1000);
  if (AX12_FIRMWARE_SHOWS_ALARM_LED) {
    /* 250 ms on, 250 ms off: 4 transitions a second. */
    assert_in_range(blinks, 3, 5);
  }
}

/* After the condition cleared: the LED stops within 2 s (plus a tick); Torque Enable 1 (and,
 * in ax12a, Torque Limit rewritten) brings torque back to stay. */
static void expect_recovers(rig_t *r, uint8_t bit, uint16_t torque_limit) {
  assert_int_equal(ping_error(r) & bit, 0);
  run_ms(r, 2100);
  assert_int_equal(led_transitions_during(r, 1000), 0);
  assert_false(r->servo->board.led_on);
  assert_int_equal(read_u8(r, CT_ADDR_TORQUE_ENABLE), 0); /* stays off after the condition cleared */
  if (is_ax12a(r)) {
    write_u16(r, CT_ADDR_TORQUE_LIMIT, torque_limit);
  }
  write_u8(r, CT_ADDR_TORQUE_ENABLE, 1);
  run_ms(r, 1500);
  assert_int_equal(read_u8(r, CT_ADDR_TORQUE_ENABLE), 1);
  assert_int_equal(ping_error(r) & bit, 0);
}

static void arm_alarm(rig_t *r, uint8_t bit) {
  write_u8(r, CT_ADDR_ALARM_LED, bit);
  write_u8(r, CT_ADDR_ALARM_SHUTDOWN, bit);
}

static void voltage_alarm(const char *profile) {
  rig_t r;
  rig_open(&r, profile, NULL);
  arm_alarm(&r, DXL_ERR_VOLTAGE);
  write_u8(&r, CT_ADDR_TORQUE_ENABLE, 1);
  run_ms(&r, 50);
  assert_int_equal(read_u8(&r, CT_ADDR_TORQUE_ENABLE), 1);
  assert_int_equal(read_u8(&r, CT_ADDR_PRESENT_VOLTAGE), 96);
  /* Below the lowest limit (6.0 V). */
  ax12_plant_set_supply_v(&r.servo->plant, 5.0);
  run_ms(&r, 20);
  assert_in_range(read_u8(&r, CT_ADDR_PRESENT_VOLTAGE), 49, 50);
  expect_tripped(&r, DXL_ERR_VOLTAGE);
  ax12_plant_set_supply_v(&r.servo->plant, 9.6);
  run_ms(&r, 20);
  expect_recovers(&r, DXL_ERR_VOLTAGE, 1023);
  /* Above the highest limit (19.0 V ax12, 14.0 V ax12a). */
  ax12_plant_set_supply_v(&r.servo->plant, is_ax12a(&r) ? 15.0 : 20.0);
  run_ms(&r, 20);
  expect_tripped(&r, DXL_ERR_VOLTAGE);
  /* Still out of limits: Torque Enable 1 trips again at once. */
  write_u8(&r, CT_ADDR_TORQUE_ENABLE, 1);
  run_ms(&r, 5);
  assert_int_equal(read_u8(&r, CT_ADDR_TORQUE_ENABLE), 0);
  ax12_plant_set_supply_v(&r.servo->plant, 9.6);
  run_ms(&r, 20);
  expect_recovers(&r, DXL_ERR_VOLTAGE, 1023);
  rig_close(&r);
}

static void test_voltage_alarm_ax12(void **state) {
  (void)state;
  voltage_alarm("ax12");
}

static void test_voltage_alarm_ax12a(void **state) {
  (void)state;
  voltage_alarm("ax12a");
}

/* Stall against a load beyond what the servo lifts until the sensor passes the limit. */
static void overheating_alarm(const char *profile) {
  plant_options_t world;
  plant_options_default(&world);
  world.ambient_c = 60.0;
  rig_t r;
  rig_open(&r, profile, &world);
  arm_alarm(&r, DXL_ERR_OVERHEATING);
  const uint8_t t0 = read_u8(&r, CT_ADDR_PRESENT_TEMPERATURE);
  assert_in_range(t0, 59, 61);
  write_u8(&r, CT_ADDR_HIGHEST_LIMIT_TEMP, (uint8_t)(t0 + 3u));
  write_u8(&r, CT_ADDR_TORQUE_ENABLE, 1);
  /* A spring pulling CW toward 30 deg, 4 N m/rad: at the equilibrium (~55 deg) the error is
   * far past the slope, the drive full, the shaft still, the winding at stall current. */
  const ax12_load_t spring = ax12_load_spring(4.0, 30.0 * M_PI / 180.0);
  ax12_plant_set_load(&r.servo->plant, &spring);
  unsigned ms = 0;
  while (read_u8(&r, CT_ADDR_TORQUE_ENABLE) == 1) {
    assert_true(ms < 60000);
    run_ms(&r, 100);
    ms += 100;
  }
  assert_true(read_u8(&r, CT_ADDR_PRESENT_TEMPERATURE) > t0 + 3u);
  assert_true(ms > 1000); /* it took heating, not a glitch */
  expect_tripped(&r, DXL_ERR_OVERHEATING);
  /* Recovery: raise the limit above the temperature (cooling would take minutes). */
  write_u8(&r, CT_ADDR_HIGHEST_LIMIT_TEMP, 100);
  ax12_plant_set_load(&r.servo->plant, &(ax12_load_t){.kind = AX12_LOAD_NONE});
  expect_recovers(&r, DXL_ERR_OVERHEATING, 1023);
  rig_close(&r);
}

static void test_overheating_alarm_ax12(void **state) {
  (void)state;
  overheating_alarm("ax12");
}

static void test_overheating_alarm_ax12a(void **state) {
  (void)state;
  overheating_alarm("ax12a");
}

/* A load beyond what Torque Limit allows: the output is pushed back and held past
 * margin + slope, stalled, for the overload window (1 s). */
static void overload_alarm(const char *profile) {
  rig_t r;
  rig_open(&r, profile, NULL);
  arm_alarm(&r, DXL_ERR_OVERLOAD);
  write_u16(&r, CT_ADDR_TORQUE_LIMIT, 300);
  write_u8(&r, CT_ADDR_TORQUE_ENABLE, 1);
  run_ms(&r, 100);
  /* A spring pulling CW toward 50 deg, 1 N m/rad: the servo gives way until the spring's pull
   * equals what 300/1023 of the drive holds, far past margin + slope, and stays there. */
  ax12_load_t load = ax12_load_spring(1.0, 50.0 * M_PI / 180.0);
  ax12_plant_set_load(&r.servo->plant, &load);
  run_ms(&r, 900);
  assert_int_equal(read_u8(&r, CT_ADDR_TORQUE_ENABLE), 1); /* a transient is not an overload */
  unsigned ms = 0;
  while (read_u8(&r, CT_ADDR_TORQUE_ENABLE) == 1) {
    assert_true(ms < 3000);
    run_ms(&r, 50);
    ms += 50;
  }
  /* The overload stays latched while torque is off (docs/control.md): the reason shows. */
  expect_tripped(&r, DXL_ERR_OVERLOAD);
  run_ms(&r, 2000);
  assert_true((ping_error(&r) & DXL_ERR_OVERLOAD) != 0);
  load = ax12_load_none();
  ax12_plant_set_load(&r.servo->plant, &load);
  write_u16(&r, CT_ADDR_GOAL_POSITION, read_u16(&r, CT_ADDR_PRESENT_POSITION));
  if (is_ax12a(&r)) {
    write_u16(&r, CT_ADDR_TORQUE_LIMIT, 300);
  }
  write_u8(&r, CT_ADDR_TORQUE_ENABLE, 1); /* ends the latch */
  run_ms(&r, 5);
  assert_int_equal(ping_error(&r) & DXL_ERR_OVERLOAD, 0);
  run_ms(&r, 2100);
  assert_int_equal(led_transitions_during(&r, 1000), 0);
  assert_int_equal(read_u8(&r, CT_ADDR_TORQUE_ENABLE), 1);
  rig_close(&r);
}

static void test_overload_alarm_ax12(void **state) {
  (void)state;
  overload_alarm("ax12");
}

static void test_overload_alarm_ax12a(void **state) {
  (void)state;
  overload_alarm("ax12a");
}

static void angle_limit_alarm(const char *profile) {
  rig_t r;
  rig_open(&r, profile, NULL);
  arm_alarm(&r, DXL_ERR_ANGLE_LIMIT);
  write_u16(&r, CT_ADDR_CW_ANGLE_LIMIT, 200);
  write_u16(&r, CT_ADDR_CCW_ANGLE_LIMIT, 800);
  write_u8(&r, CT_ADDR_TORQUE_ENABLE, 1);
  write_u16(&r, CT_ADDR_GOAL_POSITION, 900); /* outside the limits */
  assert_true((r.last_error & DXL_ERR_ANGLE_LIMIT) != 0);
  run_ms(&r, 5);
  expect_tripped(&r, DXL_ERR_ANGLE_LIMIT);
  /* Still outside: Torque Enable 1 trips again. */
  write_u8(&r, CT_ADDR_TORQUE_ENABLE, 1);
  run_ms(&r, 5);
  assert_int_equal(read_u8(&r, CT_ADDR_TORQUE_ENABLE), 0);
  write_u16(&r, CT_ADDR_GOAL_POSITION, 700);
  expect_recovers(&r, DXL_ERR_ANGLE_LIMIT, 1023);
  /* and it moves there */
  (void)wait_until_still(&r, 2000);
  assert_in_range(read_u16(&r, CT_ADDR_PRESENT_POSITION), 695, 705);
  rig_close(&r);
}

static void test_angle_limit_alarm_ax12(void **state) {
  (void)state;
  angle_limit_alarm("ax12");
}

static void test_angle_limit_alarm_ax12a(void **state) {
  (void)state;
  angle_limit_alarm("ax12a");
}

/* ---- the simulator's batched runs (model/simavr/servo_run.c) ---- */

/* A script that exercises every path of the firmware on three moving servos: replies at
 * Return Delay Time 0 (the RX ISR), 3 (its spin) and 250 (Timer1 COMPA), broadcast PINGs that
 * collide, a SYNC_WRITE, EEPROM writes, motion with its PWM starting and stopping. Every
 * byte the master heard is appended to log (start, end, value, flags). */
#define SCRIPT_LOG_MAX 4096u

typedef struct {
  harness_t h;
  servo_t *servo[3];
  bus_rx_t log[SCRIPT_LOG_MAX];
  size_t logged;
} script_world_t;

static void script_exchange(script_world_t *w, uint8_t id, uint8_t instruction, const uint8_t *params, size_t count,
                            size_t expect) {
  uint8_t reply[HARNESS_MAX_REPLY];
  (void)harness_request(&w->h, id, instruction, params, count, expect, reply);
  for (size_t i = 0; i < master_rx_count(w->h.master) && w->logged < SCRIPT_LOG_MAX; i++) {
    w->log[w->logged++] = *master_rx(w->h.master, i);
  }
}

static void script_run(script_world_t *w, bool single_step, bool every_timer0_event) {
  memset(w, 0, sizeof(*w));
  harness_open(&w->h, "ax12", "atmega88", 1);
  plant_options_t options;
  plant_options_default(&options);
  ax12_plant_t plant;
  plant_options_build(&options, &plant);
  for (unsigned i = 0; i < 3; i++) {
    w->servo[i] = harness_add_servo(&w->h, (uint8_t)(i + 1u), 1, NULL);
    w->servo[i]->single_step = single_step;
    quiet_timer_enable(&w->servo[i]->quiet_timer0, !every_timer0_event);
    servo_attach_plant(w->servo[i], &plant);
  }
  harness_boot(&w->h, 450);
  script_exchange(w, 2, DXL_INST_WRITE, HP(CT_ADDR_RETURN_DELAY_TIME, 3), 6);   /* 3: the spin */
  script_exchange(w, 3, DXL_INST_WRITE, HP(CT_ADDR_RETURN_DELAY_TIME, 250), 6); /* 250: Timer1 COMPA */
  script_exchange(w, 1, DXL_INST_WRITE, HP(CT_ADDR_RETURN_DELAY_TIME, 0), 6);
  script_exchange(w, DXL_ID_BROADCAST, DXL_INST_WRITE, HP(CT_ADDR_TORQUE_ENABLE, 1), 0);
  script_exchange(w, DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE,
                  HP(CT_ADDR_GOAL_POSITION, 2, 1, 0x20, 0x03, 2, 0x00, 0x01, 3, 0xC0, 0x02), 0);
  for (unsigned round = 0; round < 6; round++) {
    for (uint8_t id = 1; id <= 3; id++) {
      script_exchange(w, id, DXL_INST_READ, HP(CT_ADDR_PRESENT_POSITION, 4), 10);
    }
    script_exchange(w, DXL_ID_BROADCAST, DXL_INST_PING, H_NO_PARAMS, 6); /* three at once */
    world_run_until(w->h.world, w->h.world->now + sim_ms(20));
  }
}

/* Two runs of the script heard the same bytes at the same cycles and ended at the same time;
 * each servo at the same cycle, PC and sleep count. */
static void expect_same_wire_and_clocks(const script_world_t *a, const script_world_t *b) {
  assert_true(a->logged > 100u);
  assert_int_equal(a->logged, b->logged);
  for (size_t i = 0; i < a->logged; i++) {
    assert_int_equal(a->log[i].start, b->log[i].start);
    assert_int_equal(a->log[i].end, b->log[i].end);
    assert_int_equal(a->log[i].value, b->log[i].value);
    assert_int_equal(a->log[i].flags, b->log[i].flags);
  }
  assert_int_equal(a->h.world->now, b->h.world->now);
  for (unsigned i = 0; i < 3; i++) {
    assert_int_equal(a->servo[i]->avr->cycle, b->servo[i]->avr->cycle);
    assert_int_equal(a->servo[i]->avr->pc, b->servo[i]->avr->pc);
    assert_int_equal(a->servo[i]->sleep_cycles, b->servo[i]->sleep_cycles);
  }
}

static void test_batched_runs_match_single_steps(void **state) {
  (void)state;
  static script_world_t batched, stepped;
  script_run(&batched, false, false);
  script_run(&stepped, true, false);
  expect_same_wire_and_clocks(&batched, &stepped);
  for (unsigned i = 0; i < 3; i++) {
    const avr_t *a = batched.servo[i]->avr, *b = stepped.servo[i]->avr;
    assert_memory_equal(a->data, b->data, (size_t)a->ramend + 1u); /* registers, I/O, RAM */
    assert_true(ax12_plant_angle_deg(&batched.servo[i]->plant) == ax12_plant_angle_deg(&stepped.servo[i]->plant));
  }
  /* The script did move them (PWM on). */
  assert_true(fabs(ax12_plant_angle_deg(&batched.servo[0]->plant) - 150.0) > 20.0);
  harness_close(&batched.h);
  harness_close(&stepped.h);
}

/* What a quiet Timer0 no longer simulates (model/simavr/quiet_timer.h): its count, its flags,
 * its compare pins' levels. */
static void blank_unsimulated_timer0_state(const servo_t *servo, uint8_t *data) {
  const avr_timer_t *t0 = servo->quiet_timer0.timer;
  data[t0->r_tcnt] = 0;
  data[t0->overflow.raised.reg] = 0; /* TIFR0 */
  data[((const avr_ioport_t *)servo->board.port_d)->r_pin] = 0; /* PIND: OC0A / OC0B */
}

static void test_quiet_timer0_changes_nothing_the_firmware_does(void **state) {
  (void)state;
  static script_world_t quiet, every;
  script_run(&quiet, false, false);
  script_run(&every, false, true);
  expect_same_wire_and_clocks(&quiet, &every);
  unsigned long long cancelled = 0;
  for (unsigned i = 0; i < 3; i++) {
    const avr_t *a = quiet.servo[i]->avr, *b = every.servo[i]->avr;
    const size_t size = (size_t)a->ramend + 1u;
    uint8_t *x = malloc(size), *y = malloc(size);
    assert_non_null(x);
    assert_non_null(y);
    memcpy(x, a->data, size);
    memcpy(y, b->data, size);
    /* The reference did simulate them: the overflow flag is up there (never cleared). */
    assert_true((y[every.servo[i]->quiet_timer0.timer->overflow.raised.reg] & 1u) != 0);
    blank_unsimulated_timer0_state(quiet.servo[i], x);
    blank_unsimulated_timer0_state(every.servo[i], y);
    assert_memory_equal(x, y, size); /* registers, RAM, every other I/O register */
    free(x);
    free(y);
    assert_true(ax12_plant_angle_deg(&quiet.servo[i]->plant) == ax12_plant_angle_deg(&every.servo[i]->plant));
    cancelled += quiet.servo[i]->quiet_timer0.cancelled;
    assert_int_equal(every.servo[i]->quiet_timer0.cancelled, 0);
  }
  assert_true(cancelled > 0u);
  harness_close(&quiet.h);
  harness_close(&every.h);
}

int main(void) {
  if (!AX12_FIRMWARE_SHOWS_ALARM_LED) {
    fprintf(stderr, "note: main.c does not show control_led_on() yet: LED blink counts not checked\n");
  }
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_goal_moves_output_ax12),
      cmocka_unit_test(test_goal_moves_output_ax12a),
      cmocka_unit_test(test_moving_speed_cruise),
      cmocka_unit_test(test_slopes_17_and_32_identical),
      cmocka_unit_test(test_wheel_mode_both_directions),
      cmocka_unit_test(test_torque_off_under_a_constant_load_turns_at_the_body_diodes_braking_speed),
      cmocka_unit_test(test_torque_off_a_heavy_arm_falls_braked_and_rests_hanging),
      cmocka_unit_test(test_voltage_alarm_ax12),
      cmocka_unit_test(test_voltage_alarm_ax12a),
      cmocka_unit_test(test_overheating_alarm_ax12),
      cmocka_unit_test(test_overheating_alarm_ax12a),
      cmocka_unit_test(test_overload_alarm_ax12),
      cmocka_unit_test(test_overload_alarm_ax12a),
      cmocka_unit_test(test_angle_limit_alarm_ax12),
      cmocka_unit_test(test_angle_limit_alarm_ax12a),
      cmocka_unit_test(test_batched_runs_match_single_steps),
      cmocka_unit_test(test_quiet_timer0_changes_nothing_the_firmware_does),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
