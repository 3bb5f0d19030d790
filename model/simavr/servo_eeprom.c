/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "servo_eeprom.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <avr_eeprom.h>
#include <sim_avr.h>
#include <sim_io.h>

#include "eeprom_store.h"
#include "simavr_patch.h"

static avr_eeprom_t *find_eeprom(avr_t *avr) {
  for (avr_io_t *io = avr->io_port; io; io = io->next) {
    if (io->kind && strcmp(io->kind, "eeprom") == 0) {
      return (avr_eeprom_t *)io;
    }
  }
  return NULL;
}

/* simavr 1.6: EEPE is cleared the moment a write starts; silicon keeps it set for the whole
 * write. EEPE reads 1 from the write until 3.4 ms later (one cycle before simavr raises
 * EE_READY, so a woken main loop sees the EEPROM ready). */
static avr_cycle_count_t eeprom_write_done(avr_t *avr, avr_cycle_count_t when, void *param) {
  (void)when;
  servo_t *servo = param;
  avr_regbit_clear(avr, find_eeprom(avr)->eepe);
  servo->eeprom_busy = false;
  return 0;
}

void servo_eeprom_was_reset(servo_t *servo) { servo->eeprom_busy = false; }

/* EECR write, chained to simavr's handler. simavr 1.6 workaround: holds EEPE for the write's
 * 3.4 ms and ignores a write started meanwhile (simavr would store that byte too). */
static void eecr_write(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param) {
  servo_t *servo = param;
  avr_eeprom_t *ee = find_eeprom(avr);
  const bool master_enabled = avr_regbit_get(avr, ee->eempe);
  const bool starts_write = master_enabled && ((v >> ee->eepe.bit) & ee->eepe.mask);
  if (starts_write && servo->eeprom_busy) {
    servo->eeprom_writes_while_busy++; /* silicon ignores it; simavr would store the byte */
    avr_regbit_clear(avr, ee->eempe);
    avr_regbit_set(avr, ee->eepe);
    return;
  }
  io_hook_chain(&servo->eecr_replaced, avr, addr, v);
  if (starts_write) {
    servo->eeprom_writes++;
    servo->dirty = true; /* persisted at the end of this world step */
    if (servo->persist_due) {
      __atomic_store_n(servo->persist_due, true, __ATOMIC_RELAXED); /* world.c may run servos on 2 threads */
    }
    servo->eeprom_busy = true;
    servo->last_write_at = avr->cycle;
    avr_cycle_timer_register(avr, SIM_EEPROM_WRITE_CYCLES - 1u, eeprom_write_done, servo);
  }
  if (servo->eeprom_busy) {
    avr_regbit_set(avr, ee->eepe); /* simavr's handler clears it on every EECR write */
  }
}

/* The EEPROM at power-up into image: config's explicit bytes, else the state file, else a
 * seeded factory image (written to the state file at once). */
static int prepare_image(servo_t *servo, const servo_config_t *config, uint8_t *image, char *err, size_t err_len) {
  if (config->eeprom) {
    memset(image, 0xFF, servo->eeprom_size);
    memcpy(image, config->eeprom, config->eeprom_len < servo->eeprom_size ? config->eeprom_len : servo->eeprom_size);
    return 0;
  }
  int found = 0;
  if (config->state_path) {
    found = eeprom_store_load(config->state_path, image, servo->eeprom_size, err, err_len);
    if (found < 0) {
      return -1;
    }
  }
  if (found) {
    return 0;
  }
  eeprom_store_seed(image, servo->eeprom_size, config->profile, config->id, config->baud_reg);
  if (config->state_path && eeprom_store_save(config->state_path, image, servo->eeprom_size, err, err_len) != 0) {
    return -1;
  }
  return 0;
}

int servo_eeprom_attach(servo_t *servo, const servo_config_t *config, char *err, size_t err_len) {
  avr_eeprom_t *ee = find_eeprom(servo->avr);
  if (!ee || !ee->eeprom) {
    snprintf(err, err_len, "MCU '%s' has no EEPROM in simavr", config->mcu);
    return -1;
  }
  servo->eeprom = ee->eeprom;
  servo->eeprom_size = ee->size;
  servo->persisted = malloc(servo->eeprom_size);
  if (!servo->persisted) {
    snprintf(err, err_len, "out of memory");
    return -1;
  }
  if (prepare_image(servo, config, servo->persisted, err, err_len) != 0) {
    return -1;
  }
  memcpy(servo->eeprom, servo->persisted, servo->eeprom_size);
  io_hook_write(servo->avr, ee->r_eecr, eecr_write, servo, &servo->eecr_replaced);
  return 0;
}

bool servo_eeprom_unsettled(const servo_t *servo, sim_cycles_t now) {
  return servo->dirty || servo->eeprom_busy || now < servo->last_write_at + SIM_EEPROM_WRITE_CYCLES + SERVO_EEPROM_QUIET;
}

int servo_persist(servo_t *servo) {
  if (!servo->state_path[0]) {
    servo->dirty = false;
    memcpy(servo->persisted, servo->eeprom, servo->eeprom_size);
    return 0;
  }
  if (memcmp(servo->eeprom, servo->persisted, servo->eeprom_size) == 0) {
    servo->dirty = false;
    return 0;
  }
  if (eeprom_store_save(servo->state_path, servo->eeprom, servo->eeprom_size, servo->last_error,
                        sizeof(servo->last_error)) != 0) {
    servo->persist_errors++;
    return -1;
  }
  memcpy(servo->persisted, servo->eeprom, servo->eeprom_size);
  servo->dirty = false;
  servo->persists++;
  return 1;
}

int servo_poll_persist(servo_t *servo) {
  if (!servo->dirty) {
    return 0;
  }
  return servo_persist(servo);
}
