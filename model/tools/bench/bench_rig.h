/* SPDX-License-Identifier: GPL-3.0-or-later */
/* ax12-bench's rig: a world of servos on one firmware ELF with a master at 1 Mbps, the
 * requests the measurements make (through model/bus/master_request.h). The traffic they
 * put on the bus is in bench_workload.h. */
#ifndef BENCH_RIG_H
#define BENCH_RIG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "master.h"
#include "master_request.h"
#include "packet_encode.h"
#include "servo.h"
#include "world.h"

#define US(x) ((sim_cycles_t)(x) * SIM_CYCLES_PER_US)
#define MS(x) US((x) * 1000u)
/* Longest a reply may take to start before a rig gives up: far above any reply (Return Delay
 * Time 254 is 508 us), so a late reply is measured as late rather than lost. */
#define REPLY_TIMEOUT MS(150)

/* The ELF every rig runs (argv[2]); its MCU and profile are read from its name. */
extern const char *bench_elf_path;

typedef struct {
  world_t *world;
  master_t *master;
  master_requester_t requester;
} bench_rig_t;

/* Prints "ax12-bench: what[: detail]" on stderr and exits with status 1. */
void bench_die(const char *what, const char *detail) __attribute__((noreturn));

/* Wall-clock seconds (CLOCK_MONOTONIC). */
double bench_wall_s(void);

/* Servos 1..servos (EEPROM in memory, 1 Mbps) and the master, after 300 ms of power-up. */
void bench_rig_open(bench_rig_t *r, unsigned servos);
/* The world with servos of the given IDs and the master, not yet powered up (the caller adds
 * what the servos drive first); bench_rig_power_up runs the 300 ms of power-up. */
void bench_rig_create(bench_rig_t *r, const uint8_t *ids, size_t count);
void bench_rig_power_up(bench_rig_t *r);
void bench_rig_close(bench_rig_t *r);

/* Sends bytes; returns the cycles from their last stop bit to the start of the first byte
 * heard back (0 if none came within REPLY_TIMEOUT), after the reply has ended and the line
 * has been quiet 200 us. expect_bytes 0: nothing is awaited, the line is watched
 * REPLY_TIMEOUT. */
sim_cycles_t bench_exchange(bench_rig_t *r, const uint8_t *bytes, size_t count, size_t expect_bytes);

/* WRITE of one byte; dies without a reply. */
void bench_write_byte(bench_rig_t *r, uint8_t id, uint8_t addr, uint8_t value);

/* A RAM counter of the firmware (bytes little-endian), by symbol; -1 when the ELF lacks it. */
long bench_firmware_counter(const servo_t *s, const char *symbol, unsigned bytes);

#endif
