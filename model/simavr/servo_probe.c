/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "servo_probe.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include <sim_avr.h>

#include "board.h"
#include "dxl_servo.h"
#include "elf_symbols.h"

/* dxl_servo_t holds only bytes up to held_conditions, so its layout is the same for avr-gcc
 * and for this host's compiler: the offset below is the firmware's. */
_Static_assert(offsetof(dxl_servo_t, held_conditions) == CT_SIZE + 2u + DXL_REG_SLOT_BYTES + 1u,
               "dxl_servo_t: bytes only before held_conditions");

#define AVR_SRAM_START 0x100u /* below: registers and I/O */
#define RPM_PER_RAD_S (60.0 / (2.0 * M_PI))

void servo_probe_locate(const char *elf_path, servo_probe_map_t *map) {
  uint32_t address = 0;
  /* elf_symbol_address gives data-space addresses for RAM objects */
  map->found = elf_symbol_address(elf_path, "servo", &address) && address >= AVR_SRAM_START && address <= 0xFFFFu;
  map->servo_addr = map->found ? (uint16_t)address : 0u;
}

void servo_probe_read(const servo_t *servo, const servo_probe_map_t *map, servo_probe_t *out) {
  memset(out, 0, sizeof(*out));
  const avr_t *avr = servo->avr;
  const size_t needed = (size_t)map->servo_addr + offsetof(dxl_servo_t, held_conditions) + 1u;
  if (map->found && needed <= (size_t)avr->ramend + 1u) {
    out->have_table = true;
    memcpy(out->table, &avr->data[map->servo_addr], CT_SIZE);
    out->conditions = avr->data[map->servo_addr + offsetof(dxl_servo_t, held_conditions)];
  }
  out->led_on = servo->board.led_on;
  out->duty = board_pwm_duty(&servo->board);
  out->has_plant = servo->has_plant;
  if (servo->has_plant) {
    const ax12_plant_t *p = &servo->plant;
    out->angle_deg = ax12_plant_angle_deg(p);
    out->speed_rpm = ax12_plant_speed_rad_s(p) * RPM_PER_RAD_S;
    out->motor_current_a = ax12_plant_motor_current_a(p);
    out->winding_c = ax12_plant_winding_temp_c(p);
    out->case_c = ax12_plant_case_temp_c(p);
    out->terminal_v = ax12_plant_terminal_v(p);
    out->load_torque_nm = ax12_load_torque_nm(&p->load, p->state.angle_rad);
  }
}
