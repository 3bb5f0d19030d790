/* SPDX-License-Identifier: GPL-3.0-or-later */
/* What a servo is doing now, read without touching its bus: the firmware's control table and
 * held alarm conditions straight from the MCU's RAM (the `servo` object of firmware/app/main.c,
 * found by its ELF symbol), and the plant's physics. For the live dashboard and
 * `ax12 world` (docs/dashboard.md); reading RAM costs the firmware nothing, so it may be
 * done at any rate between world steps. */
#ifndef SIM_SERVO_PROBE_H
#define SIM_SERVO_PROBE_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_table.h"
#include "servo.h"

/* Where the firmware keeps its servo object (dxl_servo_t), from the ELF. */
typedef struct {
  bool found;
  uint16_t servo_addr; /* data-space address of dxl_servo_t.table */
} servo_probe_map_t;

/* Looks the firmware's `servo` up in the ELF; map->found false when it is not there. */
void servo_probe_locate(const char *elf_path, servo_probe_map_t *map);

typedef struct {
  bool have_table;        /* the map was found: table and conditions are valid */
  uint8_t table[CT_SIZE]; /* the control table as the firmware holds it now */
  uint8_t conditions;     /* DXL_ERR_VOLTAGE | _OVERHEATING | _OVERLOAD held by the alarm layer */
  bool led_on;            /* the LED pin */
  double duty;            /* H-bridge drive, -1..+1, + = CCW */
  bool has_plant;
  double angle_deg;       /* output shaft, unwrapped; 0..300 is the pot track */
  double speed_rpm;       /* output shaft, + = CCW */
  double motor_current_a;
  double winding_c, case_c;
  double terminal_v;      /* supply at the servo's connector */
  double load_torque_nm;  /* what the load applies to the output now */
} servo_probe_t;

void servo_probe_read(const servo_t *servo, const servo_probe_map_t *map, servo_probe_t *out);

#endif
