/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "servo_flash.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <avr_flash.h>
#include <sim_avr.h>
#include <sim_io.h>

#include "boot_image.h"
#include "flash_store.h"
#include "simavr_patch.h"

/* The avr_io_t that sees every SPM first: simavr's avr_register_io() puts a module at the head
 * of the list avr_ioctl() asks in order, and servo_flash_attach() runs after the MCU's own
 * modules are registered. */
typedef struct {
  avr_io_t io;
  servo_t *servo;
} spm_io_t;

struct avr_flash_t *servo_flash_module(struct avr_t *avr) {
  for (avr_io_t *io = avr->io_port; io; io = io->next) {
    if (io->kind && strcmp(io->kind, "flash") == 0) {
      return (avr_flash_t *)io;
    }
  }
  return NULL;
}

/* The first byte of the section that reads while the RWW section is programmed: the top 1 K
 * words of the ATmega88's flash, the top 2 K words of the ATmega328P's (datasheet,
 * "Read-While-Write and No Read-While-Write Flash Sections"). */
static uint32_t nrww_start_of(const char *mcu, uint32_t flash_bytes) {
  return strcmp(mcu, "atmega328p") == 0 ? flash_bytes - 4096u : flash_bytes - 2048u;
}

static void clear_command(avr_t *avr, const avr_flash_t *f) {
  avr_regbit_clear(avr, f->selfprgen);
  avr_regbit_clear(avr, f->pgers);
  avr_regbit_clear(avr, f->pgwrt);
}

/* The end of a page erase or write's busy time (simavr 1.6 workaround): SPMEN, PGERS and
 * PGWRT clear, as on silicon at the operation's end. */
static avr_cycle_count_t spm_done(avr_t *avr, avr_cycle_count_t when, void *param) {
  (void)when;
  servo_t *servo = param;
  servo->spm_busy = false;
  clear_command(avr, servo->flash_module);
  return 0;
}

/* The SPM instruction (AVR_IOCTL_FLASH_SPM), before simavr's module: see servo_flash.h. */
static int spm_ioctl(struct avr_io_t *io, uint32_t ctl, void *param) {
  if (ctl != AVR_IOCTL_FLASH_SPM) {
    return -1;
  }
  servo_t *servo = ((spm_io_t *)io)->servo;
  avr_t *avr = io->avr;
  avr_flash_t *f = servo->flash_module;
  if (!avr_regbit_get(avr, f->selfprgen)) {
    return f->io.ioctl(&f->io, ctl, param); /* SPMEN not set: nothing happens */
  }
  if (servo->spm_busy) {
    servo->spm_ignored++; /* SPMEN is the busy flag here: the command bits were not taken */
    return 0;
  }
  if (avr->pc < servo->boot_section) { /* avr->pc: this SPM's byte address */
    servo->spm_ignored++;
    clear_command(avr, f);
    return 0;
  }
  const bool erase = avr_regbit_get(avr, f->pgers);
  const bool write = !erase && avr_regbit_get(avr, f->pgwrt);
  const bool rww_enable = !erase && !write && !avr_regbit_get(avr, f->blbset) &&
                          (f->flags & AVR_SELFPROG_HAVE_RWW) && avr_regbit_get(avr, f->rwwsre);
  const uint32_t page_bytes = f->spm_pagesize;
  const uint8_t zl = avr->data[R_ZL], zh = avr->data[R_ZH];
  const uint32_t page = ((uint32_t)zl | ((uint32_t)zh << 8)) & (servo->flash_bytes - 1u) & ~(page_bytes - 1u);
  uint8_t before[256];
  if (erase || write) {
    memcpy(before, avr->flash + page, page_bytes);
    avr->data[R_ZL] = (uint8_t)page; /* simavr 1.6 workaround: see servo_flash.h "addressing" */
    avr->data[R_ZH] = (uint8_t)(page >> 8);
  }
  const int r = f->io.ioctl(&f->io, ctl, param);
  avr->data[R_ZL] = zl;
  avr->data[R_ZH] = zh;
  if (erase || write) {
    servo->spm_page_ops++;
    if (memcmp(before, avr->flash + page, page_bytes) != 0) {
      servo->flash_dirty = true; /* persisted at the end of this world step */
      if (servo->persist_due) {
        __atomic_store_n(servo->persist_due, true, __ATOMIC_RELAXED); /* world.c may run servos on 2 threads */
      }
    }
    /* simavr 1.6 workaround: the busy time (servo_flash.h). */
    servo->spm_busy = true;
    avr_regbit_set(avr, f->selfprgen);
    avr_cycle_timer_register(avr, SERVO_SPM_BUSY_CYCLES, spm_done, servo);
    if (page < servo->nrww_start && (f->flags & AVR_SELFPROG_HAVE_RWW)) {
      servo->rww_busy = true;
      avr_regbit_set(avr, f->rwwsb);
    }
  } else if (rww_enable) {
    servo->rww_busy = false;
    avr_regbit_clear(avr, f->rwwsb);
  }
  return r;
}

/* SPMCSR write, chained to simavr's handler. simavr 1.6 workaround: while a page erase or write
 * is under way only SPMIE changes (SPMEN stays the busy flag); RWWSB, read-only, stays set
 * until the RWWSRE SPM. */
static void spmcsr_write(avr_t *avr, uint16_t addr, uint8_t v, void *param) {
  servo_t *servo = param;
  const avr_flash_t *f = servo->flash_module;
  if (servo->spm_busy) {
    const uint8_t spmie = (uint8_t)(f->flash.enable.mask << f->flash.enable.bit);
    avr->data[addr] = (uint8_t)((avr->data[addr] & ~spmie) | (v & spmie));
    return;
  }
  io_hook_chain(&servo->spmcsr_replaced, avr, addr, v);
  if (servo->rww_busy) {
    avr_regbit_set(avr, f->rwwsb);
  }
}

/* Every reset: the busy time ends (simavr dropped its timer) and RWWSB reads 0. */
static void spm_io_reset(avr_io_t *io) {
  servo_t *servo = ((spm_io_t *)io)->servo;
  servo->spm_busy = false;
  servo->rww_busy = false;
}

/* The flash file at power-up: used when it is of this build, else removed. */
static int load_state(servo_t *servo, char *err, size_t err_len) {
  const int status =
      flash_store_load(servo->flash_path, servo->flash_identity, servo->avr->flash, servo->flash_bytes, err, err_len);
  switch (status) {
  case FLASH_STORE_ABSENT:
    servo->flash_origin = SERVO_FLASH_FROM_ELF;
    return 0;
  case FLASH_STORE_LOADED:
    servo->flash_origin = SERVO_FLASH_FROM_STATE;
    return 0;
  case FLASH_STORE_OTHER_BUILD:
  case FLASH_STORE_INVALID:
    servo->flash_origin =
        status == FLASH_STORE_OTHER_BUILD ? SERVO_FLASH_DROPPED_OTHER_BUILD : SERVO_FLASH_DROPPED_INVALID;
    if (unlink(servo->flash_path) != 0 && errno != ENOENT) {
      snprintf(err, err_len, "cannot remove %s: %s", servo->flash_path, strerror(errno));
      return -1;
    }
    return 0;
  default:
    return -1;
  }
}

int servo_flash_attach(servo_t *servo, const servo_config_t *config, char *err, size_t err_len) {
  avr_t *avr = servo->avr;
  servo->flash_module = servo_flash_module(avr);
  if (!servo->flash_module || servo->flash_module->spm_pagesize > 256u) {
    snprintf(err, err_len, "MCU '%s' has no self-programming module in simavr", config->mcu);
    return -1;
  }
  servo->flash_bytes = avr->flashend + 1u;
  servo->boot_section = servo->flash_bytes - BOOT_SECTION_BYTES;
  servo->nrww_start = nrww_start_of(config->mcu, servo->flash_bytes);
  servo->flash_identity = flash_store_identity(avr->flash, servo->flash_bytes);
  if (config->state_path) {
    flash_store_path_beside(servo->flash_path, sizeof(servo->flash_path), config->state_path);
    if (load_state(servo, err, err_len) != 0) {
      return -1;
    }
  }
  spm_io_t *spm = calloc(1, sizeof(*spm));
  if (!spm) {
    snprintf(err, err_len, "out of memory");
    return -1;
  }
  spm->io.kind = "ax12-spm";
  spm->io.ioctl = spm_ioctl;
  spm->io.reset = spm_io_reset;
  spm->servo = servo;
  avr_register_io(avr, &spm->io);
  servo->spm_io = spm;
  io_hook_write(avr, servo->flash_module->r_spm, spmcsr_write, servo, &servo->spmcsr_replaced);
  return 0;
}

void servo_flash_detach(servo_t *servo) {
  free(servo->spm_io);
  servo->spm_io = NULL;
}

int servo_flash_poll_persist(servo_t *servo) {
  if (!servo->flash_dirty) {
    return 0;
  }
  if (!servo->flash_path[0]) {
    servo->flash_dirty = false;
    return 0;
  }
  if (flash_store_save(servo->flash_path, servo->flash_identity, servo->avr->flash, servo->flash_bytes,
                       servo->last_error, sizeof(servo->last_error)) != 0) {
    servo->persist_errors++;
    return -1;
  }
  servo->flash_dirty = false;
  servo->flash_persists++;
  return 1;
}
