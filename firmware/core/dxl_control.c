#include "dxl_control.h"

#include "dxl_protocol.h"

#define DIRECTION_CW_BIT 0x400u /* Present Speed / Load / wheel Moving Speed: bit 10 = CW */
#define MAGNITUDE_MASK 0x3FFu
/* Present Speed: an IIR filter (time constant 32 ticks, rounded) on the per-tick pot change,
 * kept in Present Speed units x 8 in 16 bits. One count per tick is 1000 / 2.2711 = 440.3
 * units (0.111 rpm = 2.2711 counts/s). Steps are rounded (no bias on the pot's alternating
 * 0 / 2-tick differences), and one too small to show moves the state by one, so it settles
 * exactly on a constant input (0 at rest). */
#define SPEED_FILTER_SHIFT 5u
#define SPEED_UNITS_PER_COUNT_X8 (440 * 8)
#define SPEED_FRACTION_SHIFT 3u
/* A position change larger than this in one tick is no motion (the pot is read every other
 * tick: ~2.6 counts between readings at 63 rpm, the fastest a 12 V supply allows): the pot
 * wrapped past its ends (wheel mode); the speed holds. Keeps target - speed_x8 in 16 bits. */
#define SPEED_MAX_DELTA_COUNTS 6
#define SLOPE_SHIFT_MIN 1u /* slope acts as 2..256 (scale 128..1) */

void dxl_control_init(dxl_control_t *control) {
  *control = (dxl_control_t){0};
}

/* The effective slope, the smallest power of two >= slope (2..256), as power - 1 (1..255:
 * a byte) and 256 / power in *scale. */
static uint8_t slope_power_less_one(uint8_t slope, uint8_t *scale) {
  uint8_t power_less_one = (1u << SLOPE_SHIFT_MIN) - 1u;
  uint8_t scale_now = 1u << (8u - SLOPE_SHIFT_MIN);
  while (scale_now > 1u && (uint8_t)(power_less_one + 1u) < slope) {
    power_less_one = (uint8_t)(power_less_one * 2u + 1u);
    scale_now >>= 1;
  }
  *scale = scale_now;
  return power_less_one;
}

uint8_t dxl_control_slope_shift(uint8_t slope) {
  uint8_t scale;
  uint8_t power_less_one = slope_power_less_one(slope, &scale);
  uint8_t shift = 0;
  for (; power_less_one != 0; power_less_one >>= 1) {
    shift++;
  }
  return shift;
}

/* m x 255 / 1023 = m / 4 - 3 m / 4092, and 3 m / 4092 lies in [0, 0.75]: with t the number of
 * the thresholds 0, 341, 682 that m exceeds, the floor is (m - t) >> 2 (the floor of m / 4,
 * less one exactly when m & 3 is below t; exact for every m). A 16 x 16 multiply and its
 * 32-bit shift cost the AVR about 60 cycles a tick. */
uint8_t dxl_control_duty(uint16_t magnitude) {
  const uint8_t thresholds_passed = magnitude > 682u ? 3u : magnitude > 341u ? 2u : magnitude != 0u ? 1u : 0u;
  return (uint8_t)((uint16_t)(magnitude - thresholds_passed) >> 2);
}

/* The slope acts as power = 2^shift (dxl_control_slope_shift). Past margin + power the law
 * asks for at least the limit: Torque Limit, no arithmetic (the usual case while moving).
 * Below, (limit - step) x excess / power with excess < power <= 256: excess x (256 / power)
 * is a byte, so the product / 256 is two 8 x 8 multiplies (the span's bytes), exactly,
 * without a 32-bit multiply and shift (about 70 cycles on the AVR). */
static uint16_t compliance_magnitude(int16_t error_counts, uint8_t cw_margin, uint8_t ccw_margin, uint8_t cw_slope,
                                     uint8_t ccw_slope, uint16_t punch, uint16_t torque_limit) {
  const bool position_cw_of_setpoint = error_counts > 0;
  const uint16_t magnitude = (uint16_t)(position_cw_of_setpoint ? error_counts : -error_counts);
  const uint8_t margin = position_cw_of_setpoint ? cw_margin : ccw_margin;
  if (magnitude <= margin) {
    return 0;
  }
  const uint16_t limit = torque_limit > DXL_DRIVE_MAX ? DXL_DRIVE_MAX : torque_limit;
  uint8_t scale;
  const uint8_t power_less_one = slope_power_less_one(position_cw_of_setpoint ? cw_slope : ccw_slope, &scale);
  const uint16_t excess = magnitude - margin;
  uint16_t drive = limit;
  if (excess <= power_less_one) {
    const uint16_t step = punch < limit ? punch : limit;
    const uint16_t span = limit - step;
    const uint8_t scaled = (uint8_t)((uint8_t)excess * scale);
    const uint8_t span_low = (uint8_t)span;
    const uint8_t span_high = (uint8_t)(span >> 8);
    const uint16_t low_product = (uint16_t)(span_low * scaled);
    const uint16_t high_product = (uint16_t)(span_high * scaled);
    drive = (uint16_t)(step + (uint8_t)(low_product >> 8) + high_product);
  }
  return drive;
}

int16_t dxl_control_compliance_drive(int16_t error_counts, uint8_t cw_margin, uint8_t ccw_margin, uint8_t cw_slope,
                                     uint8_t ccw_slope, uint16_t punch, uint16_t torque_limit) {
  const int16_t magnitude =
      (int16_t)compliance_magnitude(error_counts, cw_margin, ccw_margin, cw_slope, ccw_slope, punch, torque_limit);
  return error_counts > 0 ? magnitude : (int16_t)-magnitude;
}

/* Writes value to a Present Speed / Load item: magnitude (at most 1023) in bits 0..9, bit 10
 * set when negative (CW). Present Speed's only writer (Present Load is written from the drive's
 * magnitude, which is cheaper). */
static void set_signed_item(uint8_t *item, int16_t value) {
  uint16_t magnitude = (uint16_t)value;
  uint8_t direction_high = 0;
  if (value < 0) {
    magnitude = (uint16_t)-value;
    direction_high = DIRECTION_CW_BIT >> 8;
  }
  if (magnitude > MAGNITUDE_MASK) {
    magnitude = MAGNITUDE_MASK;
  }
  item[0] = (uint8_t)magnitude;
  item[1] = (uint8_t)((magnitude >> 8) | direction_high);
}

static uint16_t clamp_u16(uint16_t value, uint16_t low, uint16_t high) {
  return value < low ? low : (value > high ? high : value);
}

/* Moves the setpoint toward goal by at most the Moving Speed step (speed 0 jumps there);
 * returns whether it is at the goal now. */
static bool advance_setpoint(dxl_control_t *c, uint16_t goal_counts, uint16_t moving_speed) {
  const int32_t goal_q16 = (int32_t)goal_counts << 16;
  const uint16_t speed = moving_speed & MAGNITUDE_MASK; /* tested for 0 in 16 bits, not the
                                                          32-bit step: smaller code */
  const int32_t step_q16 = (int32_t)speed * DXL_SPEED_UNIT_Q16_PER_TICK;
  const int32_t to_goal = goal_q16 - c->setpoint_q16;
  if (speed == 0 || (to_goal <= step_q16 && to_goal >= -step_q16)) {
    c->setpoint_q16 = goal_q16;
    return true;
  }
  /* Counted from the goal, not the old setpoint: one 32-bit value less live where it is
   * inlined into main (a smaller stack frame for main, and smaller code). */
  c->setpoint_q16 = goal_q16 - (to_goal > 0 ? to_goal - step_q16 : to_goal + step_q16);
  return false;
}

/* Whether position lies farther from goal than the compliance margin on goal's side plus
 * the arrival tolerance: the servo still has its own way to go. The helpers shared by the
 * tick and dxl_control_after_write are kept out of line: one copy each (flash). */
static DXL_ONE_COPY bool away_from_goal(const uint8_t *table, uint16_t goal, uint16_t position) {
  const int16_t goal_error = (int16_t)(goal - position);
  const uint16_t magnitude = (uint16_t)(goal_error < 0 ? -goal_error : goal_error);
  const uint8_t margin = goal_error > 0 ? table[CT_ADDR_CW_COMPLIANCE_MARGIN] : table[CT_ADDR_CCW_COMPLIANCE_MARGIN];
  return magnitude > (uint16_t)(margin + DXL_ARRIVAL_TOLERANCE_COUNTS);
}

static DXL_ONE_COPY uint16_t joint_goal(const uint8_t *table) {
  return clamp_u16(ct_get_u16(table, CT_ADDR_GOAL_POSITION), ct_get_u16(table, CT_ADDR_CW_ANGLE_LIMIT),
                   ct_get_u16(table, CT_ADDR_CCW_ANGLE_LIMIT));
}

/* The wheel-mode drive magnitude: Moving Speed's, capped at Torque Limit. */
static DXL_ONE_COPY uint16_t wheel_drive(const uint8_t *table) {
  const uint16_t wanted = ct_get_u16(table, CT_ADDR_MOVING_SPEED) & MAGNITUDE_MASK;
  const uint16_t torque_limit = ct_get_u16(table, CT_ADDR_TORQUE_LIMIT);
  return wanted < torque_limit ? wanted : torque_limit;
}

void dxl_control_after_write(uint8_t *table) {
  if (table[CT_ADDR_TORQUE_ENABLE] == 0) {
    table[CT_ADDR_MOVING] = 0;
    ct_set_u16(table, CT_ADDR_PRESENT_LOAD, 0);
    return;
  }
  const bool starts = ct_is_wheel_mode(table)
                          ? wheel_drive(table) != 0
                          : away_from_goal(table, joint_goal(table), ct_get_u16(table, CT_ADDR_PRESENT_POSITION));
  if (starts) {
    table[CT_ADDR_MOVING] = 1;
  }
}

static uint8_t measured_conditions(const uint8_t *table, const dxl_sensors_t *in, bool overloaded) {
  uint8_t held = 0;
  if (in->voltage_dv < table[CT_ADDR_LOWEST_LIMIT_VOLTAGE] || in->voltage_dv > table[CT_ADDR_HIGHEST_LIMIT_VOLTAGE]) {
    held |= DXL_ERR_VOLTAGE;
  }
  if (in->temperature_c > table[CT_ADDR_HIGHEST_LIMIT_TEMP]) {
    held |= DXL_ERR_OVERHEATING;
  }
  if (overloaded) {
    held |= DXL_ERR_OVERLOAD;
  }
  return held;
}

static bool alarm_led_output(dxl_control_t *c, const uint8_t *table, uint8_t active_alarms) {
  uint16_t hold_ms = c->alarm_led_ms;
  if ((active_alarms & table[CT_ADDR_ALARM_LED]) != 0) {
    hold_ms = DXL_ALARM_LED_HOLD_MS;
  } else if (hold_ms != 0) {
    hold_ms--;
  }
  c->alarm_led_ms = hold_ms;
  uint16_t phase_ms = 0;
  bool on = table[CT_ADDR_LED] != 0;
  if (hold_ms != 0) {
    phase_ms = c->blink_phase_ms + 1u;
    if (phase_ms >= 2u * DXL_ALARM_BLINK_HALF_PERIOD_MS) {
      phase_ms = 0;
    }
    on = phase_ms < DXL_ALARM_BLINK_HALF_PERIOD_MS;
  }
  c->blink_phase_ms = phase_ms;
  return on;
}

int16_t dxl_control_tick(dxl_control_t *control, dxl_servo_t *servo, const dxl_sensors_t *sensors, bool *led_on) {
  dxl_control_t *c = control;
  uint8_t *table = servo->table;
  const uint16_t position = sensors->position_counts;

  if (!c->started) {
    c->started = true;
    c->last_position_counts = position; /* (the setpoint is set below, torque on or off) */
  }
  const int16_t delta = (int16_t)(position - c->last_position_counts);
  c->last_position_counts = position;
  int16_t speed_x8 = c->speed_x8;
  if (delta <= SPEED_MAX_DELTA_COUNTS && delta >= -SPEED_MAX_DELTA_COUNTS) {
    const int16_t target = (int16_t)(delta * SPEED_UNITS_PER_COUNT_X8);
    const int16_t diff = (int16_t)(target - speed_x8);
    int16_t step = (int16_t)((diff + (1 << (SPEED_FILTER_SHIFT - 1u))) >> SPEED_FILTER_SHIFT);
    if (step == 0) {
      step = (int16_t)((diff > 0) - (diff < 0)); /* settle exactly: at rest it reads 0 */
    }
    speed_x8 = (int16_t)(speed_x8 + step);
    c->speed_x8 = speed_x8;
  }
  const int16_t speed_units = (int16_t)((speed_x8 + (1 << (SPEED_FRACTION_SHIFT - 1u))) >> SPEED_FRACTION_SHIFT);

  ct_set_u16(table, CT_ADDR_PRESENT_POSITION, position);
  set_signed_item(&table[CT_ADDR_PRESENT_SPEED], speed_units);
  table[CT_ADDR_PRESENT_VOLTAGE] = sensors->voltage_dv;
  table[CT_ADDR_PRESENT_TEMPERATURE] = sensors->temperature_c;

  const bool torque_was_enabled = c->torque_was_enabled;
  uint16_t overload_ms = c->overload_ms;
  if (table[CT_ADDR_TORQUE_ENABLE] != 0 && !torque_was_enabled) {
    overload_ms = 0; /* Torque Enable written 1: a latched overload ends here */
  }
  /* Alarms first, so a shutdown takes effect in this tick's drive. */
  servo->held_conditions = measured_conditions(table, sensors, overload_ms >= DXL_OVERLOAD_WINDOW_MS);
  c->conditions = dxl_servo_conditions(servo);
  const uint8_t active_alarms = (uint8_t)(c->conditions | dxl_servo_take_events(servo));
  if ((active_alarms & table[CT_ADDR_ALARM_SHUTDOWN]) != 0 && table[CT_ADDR_TORQUE_ENABLE] != 0) {
    table[CT_ADDR_TORQUE_ENABLE] = 0;
#if DXL_PROFILE == DXL_PROFILE_AX12A
    ct_set_u16(table, CT_ADDR_TORQUE_LIMIT, 0);
#endif
  }
  *led_on = alarm_led_output(c, table, active_alarms);

  const bool torque_enabled = table[CT_ADDR_TORQUE_ENABLE] != 0;
  c->torque_was_enabled = torque_enabled;

  const uint16_t torque_limit = ct_get_u16(table, CT_ADDR_TORQUE_LIMIT);
  const uint16_t moving_speed = ct_get_u16(table, CT_ADDR_MOVING_SPEED);
  const bool wheel_mode = ct_is_wheel_mode(table);
  /* Torque off and wheel mode: the setpoint follows the position; torque coming on: no jump.
   * Coming on is "on now and off before"; past the first test, "off before" alone says it
   * (no torque_came_on bool: smaller on the ATmega88). */
  if (!torque_enabled || !torque_was_enabled || wheel_mode) {
    c->setpoint_q16 = (int32_t)position << 16;
  }
  /* The drive as magnitude and direction (cheaper than a signed value and its magnitude). */
  uint16_t drive_magnitude = 0;
  bool drive_cw = false;
  bool moving = false;
  if (torque_enabled && wheel_mode) {
    drive_magnitude = wheel_drive(table);
    drive_cw = (moving_speed & DIRECTION_CW_BIT) != 0;
    moving = drive_magnitude != 0;
  } else if (torque_enabled) { /* joint mode */
    const uint16_t goal = joint_goal(table);
    const bool setpoint_at_goal = advance_setpoint(c, goal, moving_speed);
    const int16_t setpoint = (int16_t)((c->setpoint_q16 + 0x8000L) >> 16);
    const int16_t error = (int16_t)(setpoint - (int16_t)position);
    const uint8_t cw_margin = table[CT_ADDR_CW_COMPLIANCE_MARGIN];
    const uint8_t ccw_margin = table[CT_ADDR_CCW_COMPLIANCE_MARGIN];
    const uint8_t cw_slope = table[CT_ADDR_CW_COMPLIANCE_SLOPE];
    const uint8_t ccw_slope = table[CT_ADDR_CCW_COMPLIANCE_SLOPE];
    drive_magnitude = compliance_magnitude(error, cw_margin, ccw_margin, cw_slope, ccw_slope,
                                           ct_get_u16(table, CT_ADDR_PUNCH), torque_limit);
    drive_cw = error <= 0;
    moving = true; /* an if, not one || (smaller on the ATmega88) */
    if (setpoint_at_goal) {
      moving = away_from_goal(table, goal, position);
    }
  }
  const int16_t drive = drive_cw ? (int16_t)-(int16_t)drive_magnitude : (int16_t)drive_magnitude;

  /* Present Speed along the drive: below the stall speed when stalled, negative when the load
   * drags the output backwards. */
  const int16_t speed_along_drive = drive_cw ? (int16_t)-speed_units : speed_units;
  /* Stalled while the law demands at least Torque Limit (past margin + slope in joint mode, or
   * any error past the margin when Punch >= Torque Limit; a capped drive in wheel mode). As
   * nested tests, not one && of three (smaller on the ATmega88). */
  bool stalled_at_limit = false;
  if (torque_limit != 0) {
    if (drive_magnitude >= torque_limit) {
      stalled_at_limit = speed_along_drive < (int16_t)DXL_OVERLOAD_STALL_SPEED;
    }
  }
  if (stalled_at_limit) {
    if (overload_ms < DXL_OVERLOAD_WINDOW_MS) {
      overload_ms++;
    }
  } else if (torque_enabled) {
    overload_ms = 0; /* with torque off (shut down by it) the overload stays latched */
  }
  c->overload_ms = overload_ms;

  /* set_signed_item(Present Load, drive) from the magnitude, which needs no cap (at most 1023:
   * Torque Limit's cap, or Moving Speed's bits 0..9): smaller on the ATmega88. */
  table[CT_ADDR_PRESENT_LOAD] = (uint8_t)drive_magnitude;
  table[CT_ADDR_PRESENT_LOAD + 1] =
      (uint8_t)((drive_magnitude >> 8) | (drive < 0 ? DIRECTION_CW_BIT >> 8 : 0u));
  table[CT_ADDR_MOVING] = moving ? 1u : 0u;
  return drive;
}
