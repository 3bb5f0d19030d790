/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "lab_client.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dxl_protocol.h"
#include "master_request.h"
#include "servo_plant.h"

/* Polled every 20 us for the reply, which must have come 20 ms after the request. */
static const master_wait_t lab_wait = {.poll_step = 20u * SIM_CYCLES_PER_US,
                                       .reply_timeout = 20000u * SIM_CYCLES_PER_US};

void lab_die(const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  fputs("ax12-lab: ", stderr);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fputc('\n', stderr);
  exit(1);
}

void lab_run_ms(lab_t *lab, double ms) {
  world_run_until(lab->world, lab->world->now + (sim_cycles_t)llround(ms * 1000.0 * SIM_CYCLES_PER_US));
}

double lab_now_ms(const lab_t *lab) { return sim_cycles_to_us(lab->world->now) / 1000.0; }

/* One instruction packet to ID 1 and its status packet (reply_len bytes); returns the reply. */
static const uint8_t *request(lab_t *lab, uint8_t instruction, const uint8_t *params, size_t n, size_t reply_len) {
  static uint8_t reply[64];
  const master_requester_t requester = world_requester(lab->world, lab->master, lab_wait);
  const master_reply_t r = master_request(&requester, 1, instruction, params, n, reply_len, reply, sizeof(reply));
  if (r.received < reply_len || reply[2] != 1) {
    lab_die("servo did not answer (instruction %u) at %.1f ms", instruction, lab_now_ms(lab));
  }
  return reply;
}

void lab_write_u8(lab_t *lab, uint8_t addr, uint8_t v) {
  (void)request(lab, DXL_INST_WRITE, (const uint8_t[]){addr, v}, 2, 6);
}

void lab_write_u16(lab_t *lab, uint8_t addr, uint16_t v) {
  (void)request(lab, DXL_INST_WRITE, (const uint8_t[]){addr, (uint8_t)(v & 0xFFu), (uint8_t)(v >> 8)}, 3, 6);
}

static uint16_t read_n(lab_t *lab, uint8_t addr, uint8_t n) {
  const uint8_t *r = request(lab, DXL_INST_READ, (const uint8_t[]){addr, n}, 2, 6u + n);
  return n == 1 ? r[5] : (uint16_t)(r[5] | (r[6] << 8));
}

uint8_t lab_read_u8(lab_t *lab, uint8_t addr) { return (uint8_t)read_n(lab, addr, 1); }

static int signed_register(uint16_t v) { return (v & 0x400u) ? -(int)(v & 0x3FFu) : (int)(v & 0x3FFu); }

lab_present_t lab_read_present(lab_t *lab) {
  const uint8_t *r = request(lab, DXL_INST_READ, (const uint8_t[]){CT_ADDR_PRESENT_POSITION, 6}, 2, 12);
  return (lab_present_t){.position = r[5] | (r[6] << 8),
                         .speed = signed_register((uint16_t)(r[7] | (r[8] << 8))),
                         .load = signed_register((uint16_t)(r[9] | (r[10] << 8)))};
}

ax12_plant_t lab_plant(const lab_options_t *o, double supply_v, double default_source_r) {
  plant_options_t w = o->world;
  w.supply_v = supply_v;
  ax12_plant_t plant;
  plant_options_build(&w, &plant);
  plant.params.supply.source_r_ohm = o->source_r_given ? o->source_r : default_source_r;
  return plant;
}

void lab_open(lab_t *lab, const lab_options_t *o, const ax12_plant_t *plant) {
  char err[512];
  eeprom_profile_t profile;
  if (!eeprom_profile_parse(o->profile, &profile)) {
    lab_die("unknown profile %s", o->profile);
  }
  lab->world = world_create(o->elf, "atmega88", profile, err, sizeof(err));
  if (!lab->world) {
    lab_die("%s", err);
  }
  lab->servo = world_add_servo(lab->world, 1, 1, NULL, err, sizeof(err));
  if (!lab->servo) {
    lab_die("%s", err);
  }
  servo_attach_plant(lab->servo, plant);
  lab->master = world_add_master(lab->world, 1000000.0);
  while (!servo_listening(lab->servo) && lab_now_ms(lab) < 1000.0) {
    lab_run_ms(lab, 1.0);
  }
  lab_run_ms(lab, 500.0);
  lab_write_u8(lab, CT_ADDR_RETURN_DELAY_TIME, 0);
  lab_run_ms(lab, 10.0); /* the EEPROM write */
  lab_write_u8(lab, CT_ADDR_ALARM_SHUTDOWN, 0);
}

void lab_close(lab_t *lab) {
  master_destroy(lab->master);
  world_destroy(lab->world);
  memset(lab, 0, sizeof(*lab));
}

void lab_set_load(lab_t *lab, ax12_load_t load) { ax12_plant_set_load(&lab->servo->plant, &load); }
