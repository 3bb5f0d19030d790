/* SPDX-License-Identifier: GPL-3.0-or-later */
/* ax12-lab's protocol client: one fresh emulated AX-12 (the firmware ELF in simavr driving
 * the plant) with a master at 1 Mbps, and the reads and writes of its control table that the
 * experiments (lab_experiments.h) make, through model/bus/master_request.h. Simulated time
 * only; a servo that stops answering ends the program (exit status 1). */
#ifndef LAB_CLIENT_H
#define LAB_CLIENT_H

#include <limits.h>
#include <stdbool.h>
#include <stdint.h>

#include "dxl_table.h" /* CT_ADDR_<NAME>: the control-table addresses the experiments use */
#include "master.h"
#include "plant.h"
#include "plant_options.h"
#include "servo.h"
#include "world.h"

typedef struct {
  char elf[PATH_MAX];
  const char *profile; /* "ax12" or "ax12a" */
  plant_options_t world;
  double source_r;     /* ohms, when source_r_given */
  bool source_r_given;
} lab_options_t;

typedef struct {
  world_t *world;
  master_t *master;
  servo_t *servo;
} lab_t;

/* Prints "ax12-lab: <message>" on stderr and exits with status 1. */
void lab_die(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));

/* The plant of o's world at supply_v, with the supply's source resistance from --source-r or
 * else default_source_r ohms. */
ax12_plant_t lab_plant(const lab_options_t *o, double supply_v, double default_source_r);

/* A fresh servo (EEPROM in memory, factory defaults) on a copy of plant, booted, Return Delay
 * Time 0 (fast polling), no alarm shutdown unless the experiment sets one. */
void lab_open(lab_t *lab, const lab_options_t *o, const ax12_plant_t *plant);
void lab_close(lab_t *lab);

void lab_run_ms(lab_t *lab, double ms);
double lab_now_ms(const lab_t *lab);

void lab_write_u8(lab_t *lab, uint8_t addr, uint8_t v);
void lab_write_u16(lab_t *lab, uint8_t addr, uint16_t v);
uint8_t lab_read_u8(lab_t *lab, uint8_t addr);

/* Present Position, Speed and Load in one READ (speed and load signed, in register units). */
typedef struct {
  int position, speed, load;
} lab_present_t;
lab_present_t lab_read_present(lab_t *lab);

/* The load on the servo's output from now on. */
void lab_set_load(lab_t *lab, ax12_load_t load);

#endif
