/* The control tick of the core (dxl_control.c) on the host: the compliance law, speed limit,
 * wheel mode, Present* items, Moving and the alarms, against a crude first-order plant.
 * The full physics and the real ELF are exercised by the simavr tests. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "dxl_control.h"
#include "dxl_protocol.h"

typedef struct {
  dxl_servo_t servo;
  dxl_control_t control;
  dxl_sensors_t sensors;
  double position; /* counts, continuous */
  double counts_per_tick_per_drive; /* crude plant: speed proportional to drive */
  bool stalled;                     /* the output is held by the world */
  double dragged_counts_per_tick;   /* when not 0: the world moves the output at this rate,
                                       whatever the drive (a load stronger than the motor) */
  int16_t drive;
  bool led;
} rig_t;

static void rig_init(rig_t *r, uint16_t position) {
  *r = (rig_t){0};
  r->position = position;
  r->counts_per_tick_per_drive = 1.0 / 1023.0; /* full drive: 1 count per ms, about 290 deg/s */
  r->sensors = (dxl_sensors_t){position, 96, 25};
  dxl_servo_power_up(&r->servo, NULL, position);
  dxl_control_init(&r->control);
}

static void run_ms(rig_t *r, unsigned ms) {
  for (unsigned i = 0; i < ms; i++) {
    r->sensors.position_counts = (uint16_t)(r->position + 0.5);
    r->drive = dxl_control_tick(&r->control, &r->servo, &r->sensors, &r->led);
    if (r->dragged_counts_per_tick != 0.0) {
      r->position += r->dragged_counts_per_tick;
    } else if (!r->stalled) {
      r->position += r->drive * r->counts_per_tick_per_drive;
      if (r->position < 0) r->position = 0;
      if (r->position > 1023) r->position = 1023;
    }
  }
}

static void write_u16(rig_t *r, uint8_t addr, uint16_t value) { ct_set_u16(r->servo.table, addr, value); }

/* A WRITE packet to the servo through the core, as a client's write is committed (no tick). */
static void write_packet(rig_t *r, uint8_t addr, const uint8_t *data, uint8_t len) {
  uint8_t params[8];
  params[0] = addr;
  memcpy(&params[1], data, len);
  const dxl_packet_t packet = {r->servo.table[CT_ADDR_ID], DXL_INST_WRITE, (uint8_t)(len + 1u), params, 0};
  dxl_response_t response;
  dxl_servo_handle(&r->servo, &packet, &response);
  assert_int_equal(response.events, 0);
}

static void write_goal(rig_t *r, uint16_t goal) {
  write_packet(r, CT_ADDR_GOAL_POSITION, (const uint8_t[]){(uint8_t)goal, (uint8_t)(goal >> 8)}, 2);
}
static uint16_t read_u16(rig_t *r, uint8_t addr) { return ct_get_u16(r->servo.table, addr); }

static void duty_is_the_floored_share_of_255_for_every_drive(void **state) {
  (void)state;
  for (uint16_t drive = 0; drive <= DXL_DRIVE_MAX; drive++) {
    assert_int_equal(dxl_control_duty(drive), drive * 255u / 1023u);
  }
}

static void slope_acts_as_the_next_power_of_two(void **state) {
  (void)state;
  assert_int_equal(dxl_control_slope_shift(1), 1);
  assert_int_equal(dxl_control_slope_shift(2), 1);
  assert_int_equal(dxl_control_slope_shift(3), 2);
  assert_int_equal(dxl_control_slope_shift(16), 4);
  assert_int_equal(dxl_control_slope_shift(17), 5);
  assert_int_equal(dxl_control_slope_shift(32), 5);
  assert_int_equal(dxl_control_slope_shift(33), 6);
  assert_int_equal(dxl_control_slope_shift(128), 7);
  assert_int_equal(dxl_control_slope_shift(129), 8);
  assert_int_equal(dxl_control_slope_shift(254), 8);
}

static void no_drive_inside_the_margin_then_punch_then_rising_to_the_limit(void **state) {
  (void)state;
  /* margin 4, slope 32 (acts as 32), punch 100, limit 900 */
  for (int16_t e = -4; e <= 4; e++) {
    assert_int_equal(dxl_control_compliance_drive(e, 4, 4, 32, 32, 100, 900), 0);
  }
  assert_int_equal(dxl_control_compliance_drive(5, 4, 4, 32, 32, 100, 900), 100 + (800 * 1) / 32);
  assert_int_equal(dxl_control_compliance_drive(-5, 4, 4, 32, 32, 100, 900), -(100 + (800 * 1) / 32));
  assert_int_equal(dxl_control_compliance_drive(20, 4, 4, 32, 32, 100, 900), 100 + (800 * 16) / 32);
  assert_int_equal(dxl_control_compliance_drive(36, 4, 4, 32, 32, 100, 900), 900);
  assert_int_equal(dxl_control_compliance_drive(500, 4, 4, 32, 32, 100, 900), 900);
  /* Punch above Torque Limit is capped by it. */
  assert_int_equal(dxl_control_compliance_drive(5, 0, 0, 32, 32, 1000, 300), 300);
}

/* The law as docs/control.md states it (step + (limit - step) x excess / 2^shift, capped at
 * the limit), in plain 64-bit arithmetic, against the firmware's for every error, slope and
 * a spread of margins, punches and limits. */
static void compliance_drive_matches_the_plain_formula_everywhere(void **state) {
  (void)state;
  static const uint8_t margins[] = {0, 1, 4, 255};
  static const uint16_t punches[] = {0, 32, 100, 1023};
  static const uint16_t limits[] = {0, 1, 300, 900, 1023, 1200};
  for (size_t m = 0; m < sizeof margins; m++) {
    for (size_t p = 0; p < sizeof punches / sizeof punches[0]; p++) {
      for (size_t l = 0; l < sizeof limits / sizeof limits[0]; l++) {
        for (unsigned slope = 0; slope <= 255; slope++) {
          const uint8_t shift = dxl_control_slope_shift((uint8_t)slope);
          for (int e = -1023; e <= 1023; e++) {
            const uint64_t magnitude = (uint64_t)(e < 0 ? -e : e);
            int64_t expected = 0;
            if (magnitude > margins[m]) {
              const uint64_t limit = limits[l] > DXL_DRIVE_MAX ? DXL_DRIVE_MAX : limits[l];
              const uint64_t step = punches[p] < limit ? punches[p] : limit;
              uint64_t drive = step + (((limit - step) * (magnitude - margins[m])) >> shift);
              drive = drive > limit ? limit : drive;
              expected = e > 0 ? (int64_t)drive : -(int64_t)drive;
            }
            const int16_t got = dxl_control_compliance_drive((int16_t)e, margins[m], margins[m], (uint8_t)slope,
                                                             (uint8_t)slope, punches[p], limits[l]);
            if (got != expected) {
              fail_msg("error %d margin %u slope %u punch %u limit %u: %d, expected %lld", e, margins[m], slope,
                       punches[p], limits[l], got, (long long)expected);
            }
          }
        }
      }
    }
  }
}

static void cw_and_ccw_sides_use_their_own_margin_and_slope(void **state) {
  (void)state;
  /* Position CW of the setpoint (positive error): CW margin 2; CCW side margin 10. */
  assert_int_not_equal(dxl_control_compliance_drive(5, 2, 10, 32, 32, 32, 1023), 0);
  assert_int_equal(dxl_control_compliance_drive(-5, 2, 10, 32, 32, 32, 1023), 0);
  assert_true(dxl_control_compliance_drive(10, 0, 0, 8, 128, 0, 1023) >
              -dxl_control_compliance_drive(-10, 0, 0, 8, 128, 0, 1023));
}

static void slopes_17_to_32_give_identical_drive(void **state) {
  (void)state;
  for (int16_t e = -300; e <= 300; e++) {
    const int16_t reference = dxl_control_compliance_drive(e, 1, 1, 32, 32, 32, 1023);
    for (uint8_t slope = 17; slope <= 32; slope++) {
      assert_int_equal(dxl_control_compliance_drive(e, 1, 1, slope, slope, 32, 1023), reference);
    }
  }
  assert_int_not_equal(dxl_control_compliance_drive(40, 1, 1, 33, 33, 32, 1023),
                       dxl_control_compliance_drive(40, 1, 1, 32, 32, 32, 1023));
}

static void a_goal_write_moves_the_output_and_moving_clears_on_arrival(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 300);
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  write_u16(&r, CT_ADDR_GOAL_POSITION, 700);
  run_ms(&r, 5);
  assert_int_equal(r.servo.table[CT_ADDR_MOVING], 1);
  assert_true(r.drive > 0);
  run_ms(&r, 3000);
  assert_int_equal(r.servo.table[CT_ADDR_MOVING], 0);
  const int error = 700 - (int)read_u16(&r, CT_ADDR_PRESENT_POSITION);
  assert_true(error >= -(int)DXL_ARRIVAL_TOLERANCE_COUNTS && error <= (int)DXL_ARRIVAL_TOLERANCE_COUNTS);
}

static void torque_off_gives_no_drive_and_goal_follows_nothing(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 300);
  write_u16(&r, CT_ADDR_GOAL_POSITION, 700);
  run_ms(&r, 100);
  assert_int_equal(r.drive, 0);
  assert_int_equal(read_u16(&r, CT_ADDR_PRESENT_POSITION), 300);
  assert_int_equal(r.servo.table[CT_ADDR_MOVING], 0);
}

static void moving_speed_limits_the_setpoint_rate(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 100);
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  write_u16(&r, CT_ADDR_MOVING_SPEED, 100); /* 11.1 rpm = 66.6 deg/s = 227 counts/s */
  write_u16(&r, CT_ADDR_GOAL_POSITION, 900);
  run_ms(&r, 1000);
  const int travelled = (int)read_u16(&r, CT_ADDR_PRESENT_POSITION) - 100;
  assert_in_range(travelled, 227 - 15, 227 + 15);
  /* Present Speed reads about the Moving Speed while cruising. */
  assert_in_range(read_u16(&r, CT_ADDR_PRESENT_SPEED) & 0x3FF, 85, 115);
  assert_int_equal(read_u16(&r, CT_ADDR_PRESENT_SPEED) & 0x400, 0);
}

static void goal_outside_the_angle_limits_stops_at_the_nearer_limit(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 500);
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  write_u16(&r, CT_ADDR_CCW_ANGLE_LIMIT, 600);
  write_u16(&r, CT_ADDR_GOAL_POSITION, 1000);
  run_ms(&r, 3000);
  assert_in_range(read_u16(&r, CT_ADDR_PRESENT_POSITION), 598, 602);
  assert_true(dxl_servo_conditions(&r.servo) & DXL_ERR_ANGLE_LIMIT);
}

static void wheel_mode_drives_both_directions(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 512);
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  write_u16(&r, CT_ADDR_CCW_ANGLE_LIMIT, 0);
  write_u16(&r, CT_ADDR_MOVING_SPEED, 300); /* CCW */
  run_ms(&r, 50);
  assert_int_equal(r.drive, 300);
  assert_true(r.position > 512);
  assert_int_equal(read_u16(&r, CT_ADDR_PRESENT_LOAD), 300);
  write_u16(&r, CT_ADDR_MOVING_SPEED, 0x400 | 200); /* CW */
  run_ms(&r, 200);
  assert_int_equal(r.drive, -200);
  assert_int_equal(read_u16(&r, CT_ADDR_PRESENT_LOAD), 0x400 | 200);
  assert_int_equal(read_u16(&r, CT_ADDR_PRESENT_SPEED) & 0x400, 0x400);
  write_u16(&r, CT_ADDR_TORQUE_LIMIT, 100);
  run_ms(&r, 1);
  assert_int_equal(r.drive, -100);
}

static void overheating_blinks_shuts_down_and_recovers_when_reenabled(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 512);
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  r.sensors.temperature_c = 86; /* ax12 limit 85; ax12a 70 */
  run_ms(&r, 1);
  assert_true(dxl_servo_conditions(&r.servo) & DXL_ERR_OVERHEATING);
  assert_int_equal(r.servo.table[CT_ADDR_TORQUE_ENABLE], 0); /* Alarm Shutdown has bit 2 in both profiles */
  int toggles = 0;
  bool last = r.led;
  for (int i = 0; i < 2000; i++) {
    run_ms(&r, 1);
    toggles += r.led != last;
    last = r.led;
  }
  assert_true(toggles >= 6); /* blinking at 2 Hz */
  /* Still hot: re-enabling trips again. */
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  run_ms(&r, 1);
  assert_int_equal(r.servo.table[CT_ADDR_TORQUE_ENABLE], 0);
  /* Cooled: the condition clears, the LED stops 2 s later, torque stays off until written. */
  r.sensors.temperature_c = 40;
  run_ms(&r, 1);
  assert_false(dxl_servo_conditions(&r.servo) & DXL_ERR_OVERHEATING);
  assert_int_equal(r.servo.table[CT_ADDR_TORQUE_ENABLE], 0);
  run_ms(&r, DXL_ALARM_LED_HOLD_MS + 5);
  for (int i = 0; i < 600; i++) {
    run_ms(&r, 1);
    assert_false(r.led);
  }
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  run_ms(&r, 10);
  assert_int_equal(r.servo.table[CT_ADDR_TORQUE_ENABLE], 1);
#if DXL_PROFILE == DXL_PROFILE_AX12A
  /* ax12a: the shutdown also zeroed Torque Limit, which must be rewritten. */
  assert_int_equal(read_u16(&r, CT_ADDR_TORQUE_LIMIT), 0);
#else
  assert_int_equal(read_u16(&r, CT_ADDR_TORQUE_LIMIT), 1023);
#endif
}

static void input_voltage_outside_the_limits_is_a_condition(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 512);
  r.sensors.voltage_dv = 55; /* below 6.0 V */
  run_ms(&r, 1);
  assert_true(dxl_servo_conditions(&r.servo) & DXL_ERR_VOLTAGE);
  r.sensors.voltage_dv = 96;
  run_ms(&r, 1);
  assert_false(dxl_servo_conditions(&r.servo) & DXL_ERR_VOLTAGE);
}

static void a_stall_at_the_torque_limit_is_an_overload_after_the_window(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 200);
  r.stalled = true;
  r.servo.table[CT_ADDR_ALARM_SHUTDOWN] = 0; /* watch the condition alone */
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  write_u16(&r, CT_ADDR_GOAL_POSITION, 800);
  run_ms(&r, DXL_OVERLOAD_WINDOW_MS - 10);
  assert_false(dxl_servo_conditions(&r.servo) & DXL_ERR_OVERLOAD);
  run_ms(&r, 20);
  assert_true(dxl_servo_conditions(&r.servo) & DXL_ERR_OVERLOAD);
  r.stalled = false;
  run_ms(&r, 50);
  assert_false(dxl_servo_conditions(&r.servo) & DXL_ERR_OVERLOAD);
}

/* docs/policy.md "Motion semantics": Moving is 1 in the first status a client can read after
 * a WRITE that moves the goal past the compliance margin, before any control tick. */
static void a_goal_write_reads_moving_at_once_before_any_tick(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 300);
  write_packet(&r, CT_ADDR_TORQUE_ENABLE, (const uint8_t[]){1}, 1);
  run_ms(&r, 20);
  assert_int_equal(r.servo.table[CT_ADDR_MOVING], 0);
  for (int i = 0; i < 10; i++) {
    const uint16_t here = read_u16(&r, CT_ADDR_PRESENT_POSITION);
    const uint16_t goal = here < 512 ? (uint16_t)(here + 600u) : (uint16_t)(here - 600u);
    write_goal(&r, goal);
    assert_int_equal(r.servo.table[CT_ADDR_MOVING], 1); /* no tick ran since the write */
    run_ms(&r, 3000);
    assert_int_equal(r.servo.table[CT_ADDR_MOVING], 0);
  }
}

static void a_goal_write_within_the_margin_does_not_start_moving(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 300);
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  run_ms(&r, 20);
  write_packet(&r, CT_ADDR_CW_COMPLIANCE_MARGIN, (const uint8_t[]){4, 4}, 2);
  write_goal(&r, (uint16_t)(read_u16(&r, CT_ADDR_PRESENT_POSITION) + 4u + DXL_ARRIVAL_TOLERANCE_COUNTS));
  assert_int_equal(r.servo.table[CT_ADDR_MOVING], 0);
  write_goal(&r, (uint16_t)(read_u16(&r, CT_ADDR_PRESENT_POSITION) + 5u + DXL_ARRIVAL_TOLERANCE_COUNTS));
  assert_int_equal(r.servo.table[CT_ADDR_MOVING], 1);
}

static void torque_off_reads_not_moving_and_no_load_at_once(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 300);
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  write_goal(&r, 900);
  run_ms(&r, 50);
  assert_int_equal(r.servo.table[CT_ADDR_MOVING], 1);
  assert_int_not_equal(read_u16(&r, CT_ADDR_PRESENT_LOAD), 0);
  write_packet(&r, CT_ADDR_TORQUE_ENABLE, (const uint8_t[]){0}, 1);
  assert_int_equal(r.servo.table[CT_ADDR_MOVING], 0);
  assert_int_equal(read_u16(&r, CT_ADDR_PRESENT_LOAD), 0);
  write_goal(&r, 100); /* torque off: a goal write does not move it */
  assert_int_equal(r.servo.table[CT_ADDR_MOVING], 0);
}

static void a_wheel_speed_write_reads_moving_at_once_unless_torque_limit_is_0(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 300);
  write_packet(&r, CT_ADDR_CW_ANGLE_LIMIT, (const uint8_t[]){0, 0, 0, 0}, 4); /* wheel mode */
  write_packet(&r, CT_ADDR_TORQUE_ENABLE, (const uint8_t[]){1}, 1);
  write_packet(&r, CT_ADDR_TORQUE_LIMIT, (const uint8_t[]){0, 0}, 2);
  write_packet(&r, CT_ADDR_MOVING_SPEED, (const uint8_t[]){0x00, 0x06}, 2); /* 512 CW */
  assert_int_equal(r.servo.table[CT_ADDR_MOVING], 0);
  write_packet(&r, CT_ADDR_TORQUE_LIMIT, (const uint8_t[]){0xFF, 0x03}, 2);
  assert_int_equal(r.servo.table[CT_ADDR_MOVING], 1);
}

/* docs/policy.md "Motion semantics": leaving wheel mode keeps Moving Speed's speed and drops
 * its direction bit, so the item stays inside the joint range 0..1023. */
static void leaving_wheel_mode_keeps_moving_speed_inside_the_joint_range(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 300);
  write_packet(&r, CT_ADDR_CW_ANGLE_LIMIT, (const uint8_t[]){0, 0, 0, 0}, 4);
  write_packet(&r, CT_ADDR_MOVING_SPEED, (const uint8_t[]){0xFF, 0x07}, 2); /* 2047: 1023 CW */
  assert_int_equal(read_u16(&r, CT_ADDR_MOVING_SPEED), 2047);
  write_packet(&r, CT_ADDR_CCW_ANGLE_LIMIT, (const uint8_t[]){0xFF, 0x03}, 2); /* joint mode */
  assert_int_equal(read_u16(&r, CT_ADDR_MOVING_SPEED), 1023);
  write_packet(&r, CT_ADDR_CCW_ANGLE_LIMIT, (const uint8_t[]){0, 0}, 2);
  write_packet(&r, CT_ADDR_MOVING_SPEED, (const uint8_t[]){0x2C, 0x05}, 2); /* 1324: 300 CW */
  write_packet(&r, CT_ADDR_CW_ANGLE_LIMIT, (const uint8_t[]){1, 0}, 2);
  assert_int_equal(read_u16(&r, CT_ADDR_MOVING_SPEED), 300);
}

/* docs/policy.md "Alarms": a load that drags the output backwards while the drive is at Torque
 * Limit is an overload, like a stall. */
static void a_load_dragging_the_output_backwards_is_an_overload(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 700);
  r.servo.table[CT_ADDR_ALARM_SHUTDOWN] = 0;
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  write_goal(&r, 900);
  r.dragged_counts_per_tick = -0.3; /* about 30 rpm the wrong way */
  run_ms(&r, 500);
  assert_true(r.drive > 0);
  assert_true(read_u16(&r, CT_ADDR_PRESENT_SPEED) & 0x400u); /* moving CW: away from the goal */
  run_ms(&r, DXL_OVERLOAD_WINDOW_MS - 400);
  assert_true(dxl_servo_conditions(&r.servo) & DXL_ERR_OVERLOAD);
  r.dragged_counts_per_tick = 0.0; /* the load goes: it reaches the goal, the overload ends */
  run_ms(&r, 3000);
  assert_false(dxl_servo_conditions(&r.servo) & DXL_ERR_OVERLOAD);
}

static void an_overload_shutdown_stays_latched_until_torque_enable_is_written(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 200);
  r.stalled = true;
  r.servo.table[CT_ADDR_ALARM_SHUTDOWN] = DXL_ERR_OVERLOAD;
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  write_u16(&r, CT_ADDR_GOAL_POSITION, 800);
  run_ms(&r, DXL_OVERLOAD_WINDOW_MS + 5);
  assert_int_equal(r.servo.table[CT_ADDR_TORQUE_ENABLE], 0);
  r.stalled = false;
  run_ms(&r, 500);
  assert_true(dxl_servo_conditions(&r.servo) & DXL_ERR_OVERLOAD); /* the reason stays visible */
  write_u16(&r, CT_ADDR_GOAL_POSITION, read_u16(&r, CT_ADDR_PRESENT_POSITION));
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  run_ms(&r, 1);
  assert_int_equal(r.servo.table[CT_ADDR_TORQUE_ENABLE], 1);
  assert_false(dxl_servo_conditions(&r.servo) & DXL_ERR_OVERLOAD);
}

/* docs/policy.md "Alarms": an Overload raised stays raised while torque is off, whatever
 * turned it off (here a client), until Torque Enable is written 1. */
static void an_overload_stays_raised_while_a_client_has_torque_off(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 200);
  r.stalled = true;
  r.servo.table[CT_ADDR_ALARM_SHUTDOWN] = 0; /* no shutdown: the client turns torque off */
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  write_u16(&r, CT_ADDR_GOAL_POSITION, 800);
  run_ms(&r, DXL_OVERLOAD_WINDOW_MS + 5);
  assert_true(dxl_servo_conditions(&r.servo) & DXL_ERR_OVERLOAD);
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 0;
  r.stalled = false;
  run_ms(&r, 500);
  assert_true(dxl_servo_conditions(&r.servo) & DXL_ERR_OVERLOAD);
  write_u16(&r, CT_ADDR_GOAL_POSITION, read_u16(&r, CT_ADDR_PRESENT_POSITION));
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  run_ms(&r, 1);
  assert_false(dxl_servo_conditions(&r.servo) & DXL_ERR_OVERLOAD);
}

static void present_speed_reads_the_rate_and_zero_at_rest(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 100);
  r.counts_per_tick_per_drive = 0.5 / 1023.0; /* 0.5 count/ms = 220 units at full drive */
  r.servo.table[CT_ADDR_TORQUE_ENABLE] = 1;
  write_u16(&r, CT_ADDR_CW_ANGLE_LIMIT, 0);
  write_u16(&r, CT_ADDR_CCW_ANGLE_LIMIT, 0);
  write_u16(&r, CT_ADDR_MOVING_SPEED, 1023);
  run_ms(&r, 400);
  assert_in_range(read_u16(&r, CT_ADDR_PRESENT_SPEED), 215, 225);
  write_u16(&r, CT_ADDR_MOVING_SPEED, 0);
  run_ms(&r, 400);
  assert_int_equal(read_u16(&r, CT_ADDR_PRESENT_SPEED), 0);
}

static void events_blink_the_led_when_their_bit_is_set(void **state) {
  (void)state;
  rig_t r;
  rig_init(&r, 512);
  r.servo.table[CT_ADDR_ALARM_LED] = DXL_ERR_RANGE;
  r.servo.pending_events = DXL_ERR_RANGE;
  int on = 0;
  for (int i = 0; i < 1000; i++) {
    run_ms(&r, 1);
    on += r.led;
  }
  assert_in_range(on, 400, 600);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(duty_is_the_floored_share_of_255_for_every_drive),
      cmocka_unit_test(slope_acts_as_the_next_power_of_two),
      cmocka_unit_test(no_drive_inside_the_margin_then_punch_then_rising_to_the_limit),
      cmocka_unit_test(compliance_drive_matches_the_plain_formula_everywhere),
      cmocka_unit_test(cw_and_ccw_sides_use_their_own_margin_and_slope),
      cmocka_unit_test(slopes_17_to_32_give_identical_drive),
      cmocka_unit_test(a_goal_write_moves_the_output_and_moving_clears_on_arrival),
      cmocka_unit_test(torque_off_gives_no_drive_and_goal_follows_nothing),
      cmocka_unit_test(moving_speed_limits_the_setpoint_rate),
      cmocka_unit_test(goal_outside_the_angle_limits_stops_at_the_nearer_limit),
      cmocka_unit_test(wheel_mode_drives_both_directions),
      cmocka_unit_test(overheating_blinks_shuts_down_and_recovers_when_reenabled),
      cmocka_unit_test(input_voltage_outside_the_limits_is_a_condition),
      cmocka_unit_test(a_stall_at_the_torque_limit_is_an_overload_after_the_window),
      cmocka_unit_test(an_overload_shutdown_stays_latched_until_torque_enable_is_written),
      cmocka_unit_test(an_overload_stays_raised_while_a_client_has_torque_off),
      cmocka_unit_test(present_speed_reads_the_rate_and_zero_at_rest),
      cmocka_unit_test(events_blink_the_led_when_their_bit_is_set),
      cmocka_unit_test(a_goal_write_reads_moving_at_once_before_any_tick),
      cmocka_unit_test(a_goal_write_within_the_margin_does_not_start_moving),
      cmocka_unit_test(torque_off_reads_not_moving_and_no_load_at_once),
      cmocka_unit_test(a_wheel_speed_write_reads_moving_at_once_unless_torque_limit_is_0),
      cmocka_unit_test(leaving_wheel_mode_keeps_moving_speed_inside_the_joint_range),
      cmocka_unit_test(a_load_dragging_the_output_backwards_is_an_overload),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
