/* The AX-12 control table, defined once (docs/policy.md "Control table").
 *
 * X(NAME, address, size_bytes, access_ax12, access_ax12a, min, max, default_ax12, default_ax12a)
 *
 * access: CT_R read-only, CT_RW writable, CT_NONE reserved (reads 0, writes are Range Errors).
 * min/max bound the value written (16-bit items as the 16-bit value). Addresses 0..23 are the
 * EEPROM area, 24..49 RAM. Defaults marked CT_DEF_RUNTIME are filled at power-up (Goal
 * Position, Torque Limit) or measured (Present*, calibration).
 *
 * Moving Speed's max is 1023 in joint mode and 2047 in wheel mode; dxl_table.c widens it.
 */
#ifndef CT_ITEMS_H
#define CT_ITEMS_H

#define CT_ITEMS(X) \
  X(MODEL_NUMBER,          0, 2, CT_R,    CT_R,    0,    0,   12,   12) \
  X(FIRMWARE_VERSION,      2, 1, CT_R,    CT_R,    0,    0,   DXL_FIRMWARE_VERSION_AX12, DXL_FIRMWARE_VERSION_AX12A) \
  X(ID,                    3, 1, CT_RW,   CT_RW,   0,  253,    1,    1) \
  X(BAUD_RATE,             4, 1, CT_RW,   CT_RW,   0,  254,    1,    1) \
  X(RETURN_DELAY_TIME,     5, 1, CT_RW,   CT_RW,   0,  254,  250,  250) \
  X(CW_ANGLE_LIMIT,        6, 2, CT_RW,   CT_RW,   0, 1023,    0,    0) \
  X(CCW_ANGLE_LIMIT,       8, 2, CT_RW,   CT_RW,   0, 1023, 1023, 1023) \
  X(RESERVED_10,          10, 1, CT_NONE, CT_NONE, 0,    0,    0,    0) \
  X(HIGHEST_LIMIT_TEMP,   11, 1, CT_RW,   CT_RW,   0,  150,   85,   70) \
  X(LOWEST_LIMIT_VOLTAGE, 12, 1, CT_RW,   CT_RW,  50,  250,   60,   60) \
  X(HIGHEST_LIMIT_VOLTAGE,13, 1, CT_RW,   CT_RW,  50,  250,  190,  140) \
  X(MAX_TORQUE,           14, 2, CT_RW,   CT_RW,   0, 1023, 1023, 1023) \
  X(STATUS_RETURN_LEVEL,  16, 1, CT_RW,   CT_RW,   0,    2,    2,    2) \
  X(ALARM_LED,            17, 1, CT_RW,   CT_RW,   0,  127,    4,   36) \
  X(ALARM_SHUTDOWN,       18, 1, CT_RW,   CT_RW,   0,  127,    4,   36) \
  X(RESERVED_19,          19, 1, CT_RW,   CT_RW,   0,    1,    0,    0) \
  X(DOWN_CALIBRATION,     20, 2, CT_R,    CT_R,    0,    0,  DXL_DOWN_CALIBRATION, DXL_DOWN_CALIBRATION) \
  X(UP_CALIBRATION,       22, 2, CT_R,    CT_R,    0,    0,  DXL_UP_CALIBRATION, DXL_UP_CALIBRATION) \
  X(TORQUE_ENABLE,        24, 1, CT_RW,   CT_RW,   0,    1,    0,    0) \
  X(LED,                  25, 1, CT_RW,   CT_RW,   0,    1,    0,    0) \
  X(CW_COMPLIANCE_MARGIN, 26, 1, CT_RW,   CT_RW,   0,  254,    0,    1) \
  X(CCW_COMPLIANCE_MARGIN,27, 1, CT_RW,   CT_RW,   0,  254,    0,    1) \
  X(CW_COMPLIANCE_SLOPE,  28, 1, CT_RW,   CT_RW,   1,  254,   32,   32) \
  X(CCW_COMPLIANCE_SLOPE, 29, 1, CT_RW,   CT_RW,   1,  254,   32,   32) \
  X(GOAL_POSITION,        30, 2, CT_RW,   CT_RW,   0, 1023,    0,    0) \
  X(MOVING_SPEED,         32, 2, CT_RW,   CT_RW,   0, 1023,    0,    0) \
  X(TORQUE_LIMIT,         34, 2, CT_RW,   CT_RW,   0, 1023, 1023, 1023) \
  X(PRESENT_POSITION,     36, 2, CT_R,    CT_R,    0,    0,    0,    0) \
  X(PRESENT_SPEED,        38, 2, CT_R,    CT_R,    0,    0,    0,    0) \
  X(PRESENT_LOAD,         40, 2, CT_R,    CT_R,    0,    0,    0,    0) \
  X(PRESENT_VOLTAGE,      42, 1, CT_R,    CT_R,    0,    0,    0,    0) \
  X(PRESENT_TEMPERATURE,  43, 1, CT_R,    CT_R,    0,    0,    0,    0) \
  X(REGISTERED_INSTRUCTION,44,1, CT_RW,   CT_R,    0,    1,    0,    0) \
  X(RESERVED_45,          45, 1, CT_NONE, CT_NONE, 0,    0,    0,    0) \
  X(MOVING,               46, 1, CT_R,    CT_R,    0,    0,    0,    0) \
  X(LOCK,                 47, 1, CT_RW,   CT_RW,   1,    1,    0,    0) \
  X(PUNCH,                48, 2, CT_RW,   CT_RW,   0, 1023,   32,   32)

/* Factory calibration of the pot (addresses 20..23): the raw ADC counts at the two ends of
 * travel. This firmware maps the pot linearly, so they record the ideal ends. */
#define DXL_DOWN_CALIBRATION 0
#define DXL_UP_CALIBRATION 1023

#endif
