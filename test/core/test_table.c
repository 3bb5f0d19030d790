/* The control table (dxl_table.h, ct_items.h) against docs/policy.md "Control table". */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#include <cmocka.h>

#include "dxl_servo.h"
#include "dxl_protocol.h"
#include "dxl_table.h"
#include "policy_table.h"

static uint8_t policy_access_of(uint8_t ct_access) {
  return ct_access == CT_RW ? POL_RW : ct_access == CT_R ? POL_R : POL_NONE;
}

static void test_every_address_belongs_to_the_item_policy_names(void **state) {
  (void)state;
  assert_int_equal(CT_SIZE, POL_TABLE_SIZE);
  assert_int_equal(CT_EEPROM_SIZE, POL_EEPROM_SIZE);
  assert_int_equal(CT_ITEM_COUNT, POL_ITEM_COUNT);
  for (size_t i = 0; i < POL_ITEM_COUNT; i++) {
    const pol_item_t *p = &pol_items[i];
    for (uint8_t a = p->addr; a < p->addr + p->size_bytes; a++) {
      const ct_desc_t d = ct_item_at(a);
      if (d.addr != p->addr || d.size_bytes != p->size_bytes) {
        fail_msg("address %u: core item at %u size %u, policy %s at %u size %u", a, d.addr, d.size_bytes, p->name,
                 p->addr, p->size_bytes);
      }
    }
  }
}

static void test_access_and_write_ranges_follow_policy(void **state) {
  (void)state;
  for (size_t i = 0; i < POL_ITEM_COUNT; i++) {
    const pol_item_t *p = &pol_items[i];
    const ct_desc_t d = ct_item_at(p->addr);
    if (policy_access_of(d.access) != p->access) {
      fail_msg("%s: access %u, policy %u", p->name, d.access, p->access);
    }
    if (p->access == POL_RW && (d.min != p->min || d.max != p->max)) {
      fail_msg("%s: range %u..%u, policy %u..%u", p->name, d.min, d.max, p->min, p->max);
    }
  }
}

static void test_power_up_values_follow_policy_for_this_profile(void **state) {
  (void)state;
  dxl_servo_t servo;
  dxl_servo_power_up(&servo, NULL, POL_PRESENT_POSITION_AT_POWER_UP);
  for (size_t i = 0; i < POL_ITEM_COUNT; i++) {
    const pol_item_t *p = &pol_items[i];
    const uint16_t value = p->size_bytes == 2 ? ct_get_u16(servo.table, p->addr) : servo.table[p->addr];
    if (value != p->power_up_value) {
      fail_msg("%s (address %u) is %u after power-up, the policy says %u", p->name, p->addr, value, p->power_up_value);
    }
  }
}

static void test_the_reg_write_slot_holds_the_longest_writable_window(void **state) {
  (void)state;
  assert_int_equal(DXL_REG_SLOT_BYTES, ct_longest_writable_run());
  /* and that window is 24..35 in the policy's table: 12 bytes */
  size_t longest = 0;
  size_t run = 0;
  for (uint8_t a = 0; a < POL_TABLE_SIZE; a++) {
    const pol_item_t *item = NULL;
    for (size_t i = 0; i < POL_ITEM_COUNT; i++) {
      if (a >= pol_items[i].addr && a < pol_items[i].addr + pol_items[i].size_bytes) {
        item = &pol_items[i];
      }
    }
    assert_non_null(item);
    run = item->access == POL_RW ? run + 1 : 0;
    longest = run > longest ? run : longest;
  }
  assert_int_equal(longest, DXL_REG_SLOT_BYTES);
}

static void test_16_bit_items_are_little_endian(void **state) {
  (void)state;
  uint8_t table[CT_SIZE] = {0};
  ct_set_u16(table, CT_ADDR_GOAL_POSITION, 0x03FF);
  assert_int_equal(table[30], 0xFF);
  assert_int_equal(table[31], 0x03);
  assert_int_equal(ct_get_u16(table, CT_ADDR_GOAL_POSITION), 0x03FF);
}

static void test_wheel_mode_is_both_angle_limits_zero(void **state) {
  (void)state;
  uint8_t table[CT_SIZE] = {0};
  assert_true(ct_is_wheel_mode(table));
  ct_set_u16(table, CT_ADDR_CCW_ANGLE_LIMIT, 1);
  assert_false(ct_is_wheel_mode(table));
  ct_set_u16(table, CT_ADDR_CCW_ANGLE_LIMIT, 0);
  ct_set_u16(table, CT_ADDR_CW_ANGLE_LIMIT, 0x100);
  assert_false(ct_is_wheel_mode(table));
}

static void test_power_up_takes_torque_limit_from_max_torque_and_goal_from_present_position(void **state) {
  (void)state;
  dxl_servo_t servo;
  dxl_servo_power_up(&servo, NULL, 0);
  uint8_t eeprom[CT_EEPROM_SIZE];
  memcpy(eeprom, servo.table, sizeof eeprom);
  eeprom[CT_ADDR_MAX_TORQUE] = 0xFF;
  eeprom[CT_ADDR_MAX_TORQUE + 1] = 0x01;
  dxl_servo_power_up(&servo, eeprom, 300);
  assert_int_equal(ct_get_u16(servo.table, CT_ADDR_TORQUE_LIMIT), 0x1FF);
  assert_int_equal(ct_get_u16(servo.table, CT_ADDR_GOAL_POSITION), 300);
  assert_int_equal(ct_get_u16(servo.table, CT_ADDR_PRESENT_POSITION), 300);
  assert_int_equal(servo.table[CT_ADDR_TORQUE_ENABLE], 0);
}

static void test_power_up_takes_model_version_and_calibration_from_the_firmware(void **state) {
  (void)state;
  dxl_servo_t servo;
  uint8_t eeprom[CT_EEPROM_SIZE];
  memset(eeprom, 0x55, sizeof eeprom);
  dxl_servo_power_up(&servo, eeprom, 512);
  assert_int_equal(ct_get_u16(servo.table, CT_ADDR_MODEL_NUMBER), 12);
  assert_int_equal(servo.table[CT_ADDR_FIRMWARE_VERSION], DXL_FIRMWARE_VERSION);
  assert_int_equal(ct_get_u16(servo.table, CT_ADDR_DOWN_CALIBRATION), DXL_DOWN_CALIBRATION);
  assert_int_equal(ct_get_u16(servo.table, CT_ADDR_UP_CALIBRATION), DXL_UP_CALIBRATION);
  assert_int_equal(servo.table[CT_ADDR_RESERVED_10], 0);
  /* the writable items in range come from the image, the others take their defaults */
  assert_int_equal(servo.table[CT_ADDR_ID], 0x55);
  assert_int_equal(servo.table[CT_ADDR_ALARM_LED], 0x55);
  assert_int_equal(servo.table[CT_ADDR_RESERVED_19], 0);
}

/* docs/policy.md "Power-up": a stored item outside the range a WRITE accepts boots at its
 * factory default, the rest as stored (an image that passed its check can still have been
 * crafted or written by another firmware). */
static void test_power_up_repairs_stored_items_out_of_range_and_keeps_the_rest(void **state) {
  (void)state;
  dxl_servo_t factory;
  dxl_servo_power_up(&factory, NULL, 512);
  uint8_t eeprom[CT_EEPROM_SIZE];
  memcpy(eeprom, factory.table, sizeof eeprom);
  eeprom[CT_ADDR_ID] = 254;
  eeprom[CT_ADDR_BAUD_RATE] = 255;
  eeprom[CT_ADDR_RETURN_DELAY_TIME] = 255;
  ct_set_u16(eeprom, CT_ADDR_CW_ANGLE_LIMIT, 54784);
  ct_set_u16(eeprom, CT_ADDR_CCW_ANGLE_LIMIT, 700);
  eeprom[CT_ADDR_HIGHEST_LIMIT_TEMP] = 151;
  eeprom[CT_ADDR_LOWEST_LIMIT_VOLTAGE] = 49;
  eeprom[CT_ADDR_HIGHEST_LIMIT_VOLTAGE] = 120;
  ct_set_u16(eeprom, CT_ADDR_MAX_TORQUE, 1024);
  eeprom[CT_ADDR_STATUS_RETURN_LEVEL] = 9;
  eeprom[CT_ADDR_ALARM_LED] = 128;
  eeprom[CT_ADDR_ALARM_SHUTDOWN] = 3;
  dxl_servo_t servo;
  dxl_servo_power_up(&servo, eeprom, 512);
  const uint8_t *t = servo.table;
  assert_int_equal(t[CT_ADDR_ID], factory.table[CT_ADDR_ID]);
  assert_int_equal(t[CT_ADDR_BAUD_RATE], factory.table[CT_ADDR_BAUD_RATE]);
  assert_int_equal(t[CT_ADDR_RETURN_DELAY_TIME], factory.table[CT_ADDR_RETURN_DELAY_TIME]);
  assert_int_equal(ct_get_u16(t, CT_ADDR_CW_ANGLE_LIMIT), ct_get_u16(factory.table, CT_ADDR_CW_ANGLE_LIMIT));
  assert_int_equal(ct_get_u16(t, CT_ADDR_CCW_ANGLE_LIMIT), 700);
  assert_int_equal(t[CT_ADDR_HIGHEST_LIMIT_TEMP], factory.table[CT_ADDR_HIGHEST_LIMIT_TEMP]);
  assert_int_equal(t[CT_ADDR_LOWEST_LIMIT_VOLTAGE], factory.table[CT_ADDR_LOWEST_LIMIT_VOLTAGE]);
  assert_int_equal(t[CT_ADDR_HIGHEST_LIMIT_VOLTAGE], 120);
  assert_int_equal(ct_get_u16(t, CT_ADDR_MAX_TORQUE), ct_get_u16(factory.table, CT_ADDR_MAX_TORQUE));
  assert_int_equal(ct_get_u16(t, CT_ADDR_TORQUE_LIMIT), ct_get_u16(factory.table, CT_ADDR_MAX_TORQUE));
  assert_int_equal(t[CT_ADDR_STATUS_RETURN_LEVEL], factory.table[CT_ADDR_STATUS_RETURN_LEVEL]);
  assert_int_equal(t[CT_ADDR_ALARM_LED], factory.table[CT_ADDR_ALARM_LED]);
  assert_int_equal(t[CT_ADDR_ALARM_SHUTDOWN], 3);
  /* Every writable item of the EEPROM area now passes the range check a WRITE makes. */
  for (uint8_t a = 0; a < CT_EEPROM_SIZE; a++) {
    const ct_desc_t d = ct_item_at(a);
    if (d.addr == a && d.access == CT_RW) {
      assert_int_equal(ct_check_write(t, d.addr, &t[d.addr], d.size_bytes), 0);
    }
  }
}

static void test_check_write_refuses_an_empty_window(void **state) {
  (void)state;
  dxl_servo_t servo;
  dxl_servo_power_up(&servo, NULL, 512);
  const uint8_t one = 1;
  assert_int_equal(ct_check_write(servo.table, CT_ADDR_LED, &one, 0), DXL_ERR_RANGE);
  assert_int_equal(ct_check_write(servo.table, CT_ADDR_LED, &one, 1), 0);
}

/* The item's value after the write is checked, whichever of its bytes the window holds: the
 * other byte as the table holds it (here a Moving Speed of 1024 in joint mode, as no write
 * leaves it, set directly). */
static void test_check_write_of_one_byte_checks_the_whole_item(void **state) {
  (void)state;
  dxl_servo_t servo;
  dxl_servo_power_up(&servo, NULL, 512);
  uint8_t *t = servo.table;
  const uint8_t low = 0;
  const uint8_t three = 3;
  t[CT_ADDR_MOVING_SPEED + 1] = 4;
  assert_int_equal(ct_check_write(t, CT_ADDR_MOVING_SPEED, &low, 1), DXL_ERR_RANGE);
  assert_int_equal(ct_check_write(t, CT_ADDR_MOVING_SPEED + 1, &three, 1), 0);
  const uint8_t torque_on_led_on[2] = {1, 1};
  t[CT_ADDR_MOVING_SPEED + 1] = 0;
  t[CT_ADDR_TORQUE_ENABLE - 1] = 4; /* Up Calibration's high byte: read-only, outside the window */
  assert_int_equal(ct_check_write(t, CT_ADDR_TORQUE_ENABLE, torque_on_led_on, 2), 0);
  assert_int_equal(ct_check_write(t, CT_ADDR_PUNCH + 1, &low, 1), 0);
  t[CT_ADDR_PUNCH] = 0xFF;
  t[CT_ADDR_PUNCH + 1] = 5;
  assert_int_equal(ct_check_write(t, CT_ADDR_PUNCH, &low, 1), DXL_ERR_RANGE);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_every_address_belongs_to_the_item_policy_names),
      cmocka_unit_test(test_access_and_write_ranges_follow_policy),
      cmocka_unit_test(test_power_up_values_follow_policy_for_this_profile),
      cmocka_unit_test(test_the_reg_write_slot_holds_the_longest_writable_window),
      cmocka_unit_test(test_16_bit_items_are_little_endian),
      cmocka_unit_test(test_wheel_mode_is_both_angle_limits_zero),
      cmocka_unit_test(test_power_up_takes_torque_limit_from_max_torque_and_goal_from_present_position),
      cmocka_unit_test(test_power_up_takes_model_version_and_calibration_from_the_firmware),
      cmocka_unit_test(test_power_up_repairs_stored_items_out_of_range_and_keeps_the_rest),
      cmocka_unit_test(test_check_write_refuses_an_empty_window),
      cmocka_unit_test(test_check_write_of_one_byte_checks_the_whole_item),
  };
  return cmocka_run_group_tests_name("control table (" AX12_PROFILE_NAME ")", tests, NULL, NULL);
}
