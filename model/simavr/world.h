/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The simulated world: servos and host nodes (test masters, the pty bridge) on one bus, all
 * advanced in lockstep by simulated time (the servos of a step on one thread or two:
 * world_set_threads).
 *
 * The step: every MCU runs to a common horizon H, then the bus finalizes the bytes that end
 * within BUS_FINALIZE_MARGIN of H. H is at most bus_lookahead() past now (a byte started in
 * a step cannot end inside it: at 1 Mbps a step is at most 144 cycles, 9 us) and never past
 * the next pending byte's finalization point, so every delivery is decided before any
 * receiver reaches it and happens at the byte's exact end cycle. */
#ifndef SIM_WORLD_H
#define SIM_WORLD_H

#include <pthread.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "bus.h"
#include "eeprom_store.h"
#include "master_request.h"
#include "servo.h"
#include "servo_boot.h"
#include "sim_time.h"

struct elf_firmware_t;

#define WORLD_MAX_SERVOS 254u

typedef struct world {
  bus_t bus;
  sim_cycles_t now;
  struct elf_firmware_t *firmware;
  servo_bootloader_t bootloader; /* bootloader.flash NULL: none (world_set_bootloader) */
  char mcu[32];
  eeprom_profile_t profile;
  servo_t *servos[WORLD_MAX_SERVOS];
  size_t servo_count;
  uint64_t steps;
  bool persist_due;       /* a servo wrote an EEPROM byte or changed its flash (servo_t.persist_due) */
  /* Second thread (world_set_threads): runs servos [split, servo_count) of every step. */
  bool worker_started;
  pthread_t worker;
  size_t split;
  sim_cycles_t work_until;
  uint32_t work_gen, done_gen; /* futex words */
  uint32_t worker_sleeping, main_sleeping;
  bool worker_stop;
  bool worker_park; /* world_park(): the worker sleeps without spinning */
  bool threads_chosen; /* world_set_threads() was called (else AX12_SIM_THREADS at the first run) */
  sim_cycles_t plant_due; /* no plant needs a step before this (servo_t.plant_due) */
  /* Optional: called after every step with the world's new time (the seam for a physics
   * model: read board_pwm_duty(), step the plant, feed board_set_pot_deg() and friends). */
  void (*after_step)(struct world *world, void *ctx);
  void *after_step_ctx;
  /* Optional: a model stepped at fixed simulated times, interleaved with the servos (a robot's
   * rigid-body physics: world_robot.h). No step of the world passes physics_due; once the world
   * reaches it (the plants stepped to it), physics_step runs and returns the next due time.
   * SIM_CYCLES_NEVER (world_create): none. */
  sim_cycles_t physics_due;
  sim_cycles_t (*physics_step)(struct world *world, void *ctx);
  void *physics_ctx;
  /* The servo opened to gdb (world_set_debugged), NULL when none. */
  servo_t *debugged;
} world_t;

/* Reads the ELF once. NULL with err set when it cannot be read. */
world_t *world_create(const char *elf_path, const char *mcu, eeprom_profile_t profile, char *err, size_t err_len);
void world_destroy(world_t *world);

/* Every servo added from now on carries the bootloader ELF at path beside the application
 * (servo_boot.h). False with err set when it is not a bootloader for the world's MCU. */
bool world_set_bootloader(world_t *world, const char *path, char *err, size_t err_len);

/* Adds a servo for slot `id`: EEPROM from state_path (NULL: in memory), seeded with `id` and
 * baud_reg when missing. Returns the servo, or NULL with err set. */
servo_t *world_add_servo(world_t *world, uint8_t id, uint8_t baud_reg, const char *state_path, char *err,
                         size_t err_len);
/* As world_add_servo with an explicit EEPROM at power-up (tests). */
servo_t *world_add_servo_with_eeprom(world_t *world, const char *name, const uint8_t *eeprom, size_t len,
                                     char *err, size_t err_len);

/* Runs the servos of each step on `threads` threads (1 or 2). Without a call, the first
 * world_run_until() takes AX12_SIM_THREADS from the environment (default 1): the second
 * thread spins between steps, which only pays when two CPUs are free for the simulation (a
 * client that busy-polls, like DynamixelSDK, or parallel tests make it much slower). Within a step the
 * servos do not interact (the bus decides deliveries only between steps), so results are the
 * same, cycle for cycle, on one thread or two. The second thread spins briefly, then sleeps
 * on a futex between steps. Returns the number in use. */
unsigned world_set_threads(world_t *world, unsigned threads);

/* About to leave the world alone for a while (real-time pacing sleeps): the second thread
 * stops spinning and sleeps until the next world_run_until(). */
void world_park(world_t *world);

/* Advances every node to time t (>= now), or less while a servo is debugged: see
 * world_set_debugged. */
void world_run_until(world_t *world, sim_cycles_t t);

/* servo (one of the world's, opened to gdb: servo_gdb.h) is debugged: while gdb holds it, the
 * world stands still (world_run_until returns at once); when gdb stops it inside a step, the
 * step ends at that cycle, every other servo run to it, and world_run_until returns there.
 * Runs the servos on one thread from then on (world_set_threads). NULL: none. */
void world_set_debugged(world_t *world, servo_t *servo);

/* True while gdb holds the debugged servo: world_run_until does not advance. */
bool world_held(const world_t *world);

/* Persists every EEPROM with a byte written, and every flash changed by SPM, since the last
 * time. Returns the number of failures. */
int world_poll_persist(world_t *world);

/* True while any servo may be in the middle of an EEPROM write sequence. */
bool world_eeprom_unsettled(const world_t *world);

/* For a clean shutdown: runs up to max_cycles more until no EEPROM write sequence is under
 * way, then persists every EEPROM and every flash changed by SPM. Returns the number of
 * failures. */
int world_settle_and_persist(world_t *world, sim_cycles_t max_cycles);

/* A requester (master_request.h) for a master on this world's bus: master_exchange() and
 * master_request() run the world with world_run_until(). */
master_requester_t world_requester(world_t *world, master_t *master, master_wait_t wait);

/* A master (master.h) on this world's bus, reading its clock, at bps bit/s. NULL if the bus
 * is full. */
master_t *world_add_master(world_t *world, double bps);

#endif
