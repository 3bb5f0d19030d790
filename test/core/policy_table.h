/* The control table of docs/policy.md, restated for the tests independently of ct_items.h, so a
 * mistake in the core's descriptor shows up as a disagreement rather than being checked
 * against itself. Access and defaults are those of the profile the test is built for. */
#ifndef POLICY_TABLE_H
#define POLICY_TABLE_H

#include <stdint.h>

#include "dxl_config.h"

#define POL_R 0  /* read-only */
#define POL_RW 1 /* writable */
#define POL_NONE 2 /* reserved: reads 0, writes are Range Errors */

#if DXL_PROFILE == DXL_PROFILE_AX12A
#define POL_PICK(ax12, ax12a) (ax12a)
#else
#define POL_PICK(ax12, ax12a) (ax12)
#endif

/* Defaults that depend on the power-up, not the factory: the host harness powers up with
 * Present Position 512, so Goal Position is 512 and Torque Limit = Max Torque = 1023. */
#define POL_PRESENT_POSITION_AT_POWER_UP 512u

typedef struct {
  const char *name;
  uint8_t addr;
  uint8_t size_bytes;
  uint8_t access;
  uint16_t min;
  uint16_t max; /* Moving Speed: joint mode; wheel mode allows 2047 */
  uint16_t power_up_value;
} pol_item_t;

static const pol_item_t pol_items[] = {
    {"Model Number", 0, 2, POL_R, 0, 0, 12},
    {"Firmware Version", 2, 1, POL_R, 0, 0, DXL_FIRMWARE_VERSION},
    {"ID", 3, 1, POL_RW, 0, 253, 1},
    {"Baud Rate", 4, 1, POL_RW, 0, 254, 1},
    {"Return Delay Time", 5, 1, POL_RW, 0, 254, 250},
    {"CW Angle Limit", 6, 2, POL_RW, 0, 1023, 0},
    {"CCW Angle Limit", 8, 2, POL_RW, 0, 1023, 1023},
    {"reserved 10", 10, 1, POL_NONE, 0, 0, 0},
    {"Highest Limit Temperature", 11, 1, POL_RW, 0, 150, POL_PICK(85, 70)},
    {"Lowest Limit Voltage", 12, 1, POL_RW, 50, 250, 60},
    {"Highest Limit Voltage", 13, 1, POL_RW, 50, 250, POL_PICK(190, 140)},
    {"Max Torque", 14, 2, POL_RW, 0, 1023, 1023},
    {"Status Return Level", 16, 1, POL_RW, 0, 2, 2},
    {"Alarm LED", 17, 1, POL_RW, 0, 127, POL_PICK(4, 36)},
    {"Alarm Shutdown", 18, 1, POL_RW, 0, 127, POL_PICK(4, 36)},
    {"reserved 19", 19, 1, POL_RW, 0, 1, 0},
    {"Down Calibration", 20, 2, POL_R, 0, 0, 0},    /* factory: the ideal lower end */
    {"Up Calibration", 22, 2, POL_R, 0, 0, 1023},   /* factory: the ideal upper end */
    {"Torque Enable", 24, 1, POL_RW, 0, 1, 0},
    {"LED", 25, 1, POL_RW, 0, 1, 0},
    {"CW Compliance Margin", 26, 1, POL_RW, 0, 254, POL_PICK(0, 1)},
    {"CCW Compliance Margin", 27, 1, POL_RW, 0, 254, POL_PICK(0, 1)},
    {"CW Compliance Slope", 28, 1, POL_RW, 1, 254, 32},
    {"CCW Compliance Slope", 29, 1, POL_RW, 1, 254, 32},
    {"Goal Position", 30, 2, POL_RW, 0, 1023, POL_PRESENT_POSITION_AT_POWER_UP},
    {"Moving Speed", 32, 2, POL_RW, 0, 1023, 0},
    {"Torque Limit", 34, 2, POL_RW, 0, 1023, 1023},
    {"Present Position", 36, 2, POL_R, 0, 0, POL_PRESENT_POSITION_AT_POWER_UP},
    {"Present Speed", 38, 2, POL_R, 0, 0, 0},
    {"Present Load", 40, 2, POL_R, 0, 0, 0},
    {"Present Voltage", 42, 1, POL_R, 0, 0, 0},     /* the control layer fills it */
    {"Present Temperature", 43, 1, POL_R, 0, 0, 0}, /* the control layer fills it */
    {"Registered Instruction", 44, 1, POL_PICK(POL_RW, POL_R), 0, 1, 0},
    {"reserved 45", 45, 1, POL_NONE, 0, 0, 0},
    {"Moving", 46, 1, POL_R, 0, 0, 0},
    {"Lock", 47, 1, POL_RW, 1, 1, 0},
    {"Punch", 48, 2, POL_RW, 0, 1023, 32},
};
#define POL_ITEM_COUNT (sizeof pol_items / sizeof pol_items[0])

#define POL_TABLE_SIZE 50u
#define POL_EEPROM_SIZE 24u
#define POL_MOVING_SPEED_WHEEL_MAX 2047u

#endif
