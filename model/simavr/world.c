/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "world.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sim_avr.h>
#include <sim_elf.h>

#include "servo_eeprom.h"
#include "servo_flash.h"
#include "servo_gdb.h"
#include "servo_plant.h"
#include "servo_run.h"
#include "sim_log.h"
#include "simavr_patch_run.h"
#include "world_threads.h"

world_t *world_create(const char *elf_path, const char *mcu, eeprom_profile_t profile, char *err, size_t err_len) {
  sim_log_install();
  world_t *world = calloc(1, sizeof(*world));
  elf_firmware_t *fw = calloc(1, sizeof(*fw));
  if (!world || !fw) {
    free(world);
    free(fw);
    snprintf(err, err_len, "out of memory");
    return NULL;
  }
  FILE *probe = fopen(elf_path, "rb");
  if (!probe) {
    snprintf(err, err_len, "firmware ELF not found: %s", elf_path);
    free(world);
    free(fw);
    return NULL;
  }
  fclose(probe);
  if (elf_read_firmware(elf_path, fw) != 0 || fw->flashsize == 0) {
    snprintf(err, err_len, "cannot load firmware ELF %s", elf_path);
    free(world);
    free(fw);
    return NULL;
  }
  if (fw->mmcu[0] && strcmp(fw->mmcu, mcu) != 0) {
    fprintf(stderr, "warning: %s says it is for %s, running it on %s\n", elf_path, fw->mmcu, mcu);
  }
  world->firmware = fw;
  snprintf(world->mcu, sizeof(world->mcu), "%s", mcu);
  world->profile = profile;
  world->plant_due = SIM_CYCLES_NEVER;
  world->physics_due = SIM_CYCLES_NEVER;
  bus_init(&world->bus);
  return world;
}

void world_destroy(world_t *world) {
  if (!world) {
    return;
  }
  (void)world_set_threads(world, 1);
  for (size_t i = 0; i < world->servo_count; i++) {
    servo_destroy(world->servos[i]);
  }
  bus_free(&world->bus);
  servo_bootloader_free(&world->bootloader);
  if (world->firmware) {
    free(world->firmware->flash);
    free(world->firmware->eeprom);
    free(world->firmware->fuse);
    free(world->firmware->lockbits);
#if ELF_SYMBOLS
    for (uint32_t i = 0; i < world->firmware->symbolcount; i++) {
      free(world->firmware->symbol[i]);
    }
    free(world->firmware->symbol);
#endif
    free(world->firmware);
  }
  free(world);
}

static servo_t *add(world_t *world, servo_config_t *config, char *err, size_t err_len) {
  if (world->servo_count >= WORLD_MAX_SERVOS) {
    snprintf(err, err_len, "too many servos (at most %u)", WORLD_MAX_SERVOS);
    return NULL;
  }
  config->firmware = world->firmware;
  config->bootloader = world->bootloader.flash ? &world->bootloader : NULL;
  config->mcu = world->mcu;
  config->profile = world->profile;
  servo_t *servo = servo_create(config, &world->bus, err, err_len);
  if (!servo) {
    return NULL;
  }
  /* A servo joins at the world's time: its clock starts there. */
  simavr_set_clock(servo->avr, world->now);
  servo->persist_due = &world->persist_due;
  servo->plant_due = &world->plant_due;
  world->servos[world->servo_count++] = servo;
  return servo;
}

bool world_set_bootloader(world_t *world, const char *path, char *err, size_t err_len) {
  servo_bootloader_free(&world->bootloader);
  return servo_bootloader_read(&world->bootloader, path, world->mcu, err, err_len);
}

servo_t *world_add_servo(world_t *world, uint8_t id, uint8_t baud_reg, const char *state_path, char *err,
                         size_t err_len) {
  char name[32];
  snprintf(name, sizeof(name), "servo-%u", (unsigned)id);
  servo_config_t config = {.name = name, .state_path = state_path, .id = id, .baud_reg = baud_reg};
  return add(world, &config, err, err_len);
}

servo_t *world_add_servo_with_eeprom(world_t *world, const char *name, const uint8_t *eeprom, size_t len,
                                     char *err, size_t err_len) {
  servo_config_t config = {.name = name, .eeprom = eeprom, .eeprom_len = len};
  return add(world, &config, err, err_len);
}

int world_poll_persist(world_t *world) {
  int failures = 0;
  for (size_t i = 0; i < world->servo_count; i++) {
    if (servo_poll_persist(world->servos[i]) < 0) {
      failures++;
    }
    if (servo_flash_poll_persist(world->servos[i]) < 0) {
      failures++;
    }
  }
  return failures;
}

/* The earliest time any servo can start a byte on the wire (see world.h). */
static sim_cycles_t earliest_wake(const world_t *world) {
  sim_cycles_t earliest = SIM_CYCLES_NEVER;
  for (size_t i = 0; i < world->servo_count; i++) {
    const sim_cycles_t e = servo_earliest_wake(world->servos[i], world->now);
    if (e < earliest) {
      earliest = e;
      if (e <= world->now) {
        break;
      }
    }
  }
  return earliest;
}

static void step_plants(world_t *world, sim_cycles_t now) {
  if (now < world->plant_due) {
    return;
  }
  sim_cycles_t due = SIM_CYCLES_NEVER;
  for (size_t i = 0; i < world->servo_count; i++) {
    servo_t *servo = world->servos[i];
    servo_step_plant(servo, now, false);
    if (servo->has_plant && servo->plant_at + SERVO_PLANT_STEP < due) {
      due = servo->plant_at + SERVO_PLANT_STEP;
    }
  }
  world->plant_due = due;
}

void world_set_debugged(world_t *world, servo_t *servo) {
  (void)world_set_threads(world, 1);
  world->debugged = servo;
}

bool world_held(const world_t *world) { return world->debugged && servo_gdb_holds(world->debugged); }

/* The debugged servo runs first (servo_gdb_run_until): when gdb stops it before the step's
 * end, the step ends where it stopped, so the others do not run past it, and its own
 * servo_run_until in world_run_servos returns at once (its clock is at the horizon). */
static sim_cycles_t run_debugged(world_t *world, sim_cycles_t horizon) {
  servo_t *servo = world->debugged;
  servo_gdb_run_until(servo, horizon);
  if (!servo_gdb_holds(servo)) {
    return horizon;
  }
  const sim_cycles_t at = servo->avr->cycle; /* >= now: a clock never goes back */
  return at < horizon ? at : horizon;
}

/* One step of world_run_until toward t. `debugged` (a constant in each caller, so the world
 * without a debugged servo pays nothing for it): the debugged servo runs first. */
static inline __attribute__((always_inline)) void step(world_t *world, sim_cycles_t t, bool debugged) {
  bus_t *bus = &world->bus;
  bus_finalize(bus, world->now);
  sim_cycles_t horizon = t;
  const sim_cycles_t wake = earliest_wake(world);
  if (wake != SIM_CYCLES_NEVER) {
    const sim_cycles_t lookahead = wake + bus_lookahead(bus);
    if (lookahead < horizon) {
      horizon = lookahead;
    }
  }
  const sim_cycles_t next_final = bus_next_finalize(bus);
  if (next_final < horizon) {
    horizon = next_final;
  }
  if (world->plant_due > world->now && world->plant_due < horizon) {
    horizon = world->plant_due;
  }
  if (world->physics_due < horizon) {
    horizon = world->physics_due;
  }
  if (debugged) {
    horizon = run_debugged(world, horizon);
  }
  world_run_servos(world, horizon);
  world->now = horizon;
  bus_finalize(bus, horizon);
  world->steps++;
  if (__atomic_load_n(&world->persist_due, __ATOMIC_RELAXED)) {
    world->persist_due = world_poll_persist(world) > 0; /* a failed write is retried */
  }
  step_plants(world, horizon);
  if (world->physics_step && horizon == world->physics_due) {
    world->physics_due = world->physics_step(world, world->physics_ctx);
  }
  if (world->after_step) {
    world->after_step(world, world->after_step_ctx);
  }
}

void world_run_until(world_t *world, sim_cycles_t t) {
  if (!world->threads_chosen) {
    world_choose_threads(world);
  }
  __atomic_store_n(&world->worker_park, false, __ATOMIC_RELAXED);
  if (__builtin_expect(world->debugged != NULL, 0)) {
    while (world->now < t && !world_held(world)) {
      step(world, t, true);
    }
    return;
  }
  while (world->now < t) {
    step(world, t, false);
  }
}

bool world_eeprom_unsettled(const world_t *world) {
  for (size_t i = 0; i < world->servo_count; i++) {
    if (servo_eeprom_unsettled(world->servos[i], world->now)) {
      return true;
    }
  }
  return false;
}

int world_settle_and_persist(world_t *world, sim_cycles_t max_cycles) {
  const sim_cycles_t limit = world->now + max_cycles;
  while (world->now < limit && world_eeprom_unsettled(world) && !world_held(world)) {
    world_run_until(world, world->now + sim_us(100));
  }
  int failures = 0;
  for (size_t i = 0; i < world->servo_count; i++) {
    if (servo_persist(world->servos[i]) < 0) {
      failures++;
    }
    if (servo_flash_poll_persist(world->servos[i]) < 0) {
      failures++;
    }
  }
  return failures;
}

static void run_world_until(void *world, sim_cycles_t t) { world_run_until(world, t); }

master_requester_t world_requester(world_t *world, master_t *master, master_wait_t wait) {
  return (master_requester_t){.master = master, .run_until = run_world_until, .scheduler = world, .wait = wait};
}

master_t *world_add_master(world_t *world, double bps) { return master_create(&world->bus, &world->now, bps); }
