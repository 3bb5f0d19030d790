/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "servo.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <avr_timer.h>
#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_elf.h>
#include <sim_io.h>

#include "fast_core.h"
#include "servo_boot.h"
#include "servo_eeprom.h"
#include "servo_flash.h"
#include "sim_log.h"
#include "simavr_patch.h"

static void set_power_on_flag(avr_t *avr) {
  if (avr->reset_flags.porf.reg) {
    avr_regbit_set(avr, avr->reset_flags.porf);
  }
}

static void servo_was_reset(void *ctx) { servo_eeprom_was_reset(ctx); }

/* The MCU's timer modules (for servo_earliest_wake) and Timer0's quieting (quiet_timer.h). */
static bool attach_timers(servo_t *servo) {
  const unsigned max = sizeof(servo->timers) / sizeof(servo->timers[0]);
  for (avr_io_t *io = servo->avr->io_port; io && servo->timer_count < max; io = io->next) {
    if (io->kind && strcmp(io->kind, "timer") == 0) {
      timer_enables_of((avr_timer_t *)io, &servo->timer_enables[servo->timer_count]);
      servo->timers[servo->timer_count++] = io;
      if (((avr_timer_t *)io)->name == '0' && !quiet_timer_attach(&servo->quiet_timer0, servo->avr, (avr_timer_t *)io)) {
        return false;
      }
    }
  }
  return true;
}

servo_t *servo_create(const servo_config_t *config, bus_t *bus, char *err, size_t err_len) {
  sim_log_install();
  servo_t *servo = calloc(1, sizeof(*servo));
  if (!servo) {
    snprintf(err, err_len, "out of memory");
    return NULL;
  }
  snprintf(servo->name, sizeof(servo->name), "%s", config->name ? config->name : "servo");
  if (config->state_path) {
    snprintf(servo->state_path, sizeof(servo->state_path), "%s", config->state_path);
  }
  avr_t *avr = avr_make_mcu_by_name(config->mcu);
  if (!avr) {
    snprintf(err, err_len, "unknown MCU '%s'", config->mcu);
    free(servo);
    return NULL;
  }
  servo->avr = avr;
  avr_init(avr);
  avr->log = LOG_ERROR;
  avr_load_firmware(avr, (elf_firmware_t *)config->firmware);
  avr->frequency = SIM_CPU_HZ;
  avr->vcc = avr->avcc = avr->aref = 5000;
  simavr_install_run_loop(avr);
  set_power_on_flag(avr);
  servo->fast_core = fast_core_wanted() ? fast_core_new(avr) : NULL;

  const elf_firmware_t *fw = config->firmware;
  if ((config->bootloader && servo_boot_attach(servo, config->bootloader, fw->flashsize, err, err_len) != 0) ||
      servo_flash_attach(servo, config, err, err_len) != 0 || servo_eeprom_attach(servo, config, err, err_len) != 0) {
    servo_destroy(servo);
    return NULL;
  }
  if (!board_attach(&servo->board, avr, bus, servo->name)) {
    snprintf(err, err_len, "MCU '%s' lacks a part the board needs (USART0, ports B/D) or the bus is full",
             config->mcu);
    servo_destroy(servo);
    return NULL;
  }
  uart_link_use_fast_interrupts(&servo->board.link, servo->fast_core != NULL);
  if (!attach_timers(servo)) {
    snprintf(err, err_len, "MCU '%s': Timer0 is not where the emulator expects it", config->mcu);
    servo_destroy(servo);
    return NULL;
  }
  servo->board.on_reset = servo_was_reset;
  servo->board.on_reset_ctx = servo;
  servo->ready = true;
  return servo;
}

void servo_destroy(servo_t *servo) {
  if (!servo) {
    return;
  }
  if (servo->ready && servo->state_path[0] && !servo->persist_errors) {
    (void)servo_persist(servo);
    (void)servo_flash_poll_persist(servo);
  }
  if (servo->avr) {
    avr_terminate(servo->avr);
    board_detach(&servo->board);
    servo_flash_detach(servo);
    free(servo->avr);
  }
  fast_core_free(servo->fast_core);
  free(servo->persisted);
  free(servo);
}

bool servo_listening(const servo_t *servo) {
  return !servo->halted && avr_regbit_get(servo->avr, servo->board.link.uart->rxen);
}

/* By then a bootloader that has not started the application stays in it: its '#' window
 * (32.8 ms) and its check of the largest application (32 KB at about 9 cycles a byte, 18 ms),
 * with a margin. */
#define BOOT_WINDOW_DONE_MS 150u

bool servo_ready_for_clients(const servo_t *servo, sim_cycles_t since_power_up) {
  if (!servo_listening(servo)) {
    return false;
  }
  const avr_t *avr = servo->avr;
  if (avr->reset_pc == 0) {
    return true; /* no bootloader */
  }
  if (avr->pc < avr->reset_pc && avr_regbit_get(servo->avr, servo->board.link.uart->rxc.enable)) {
    /* The application runs and has set up its USART: the receiver the bootloader left on (at
     * its own baud) does not say so, this project's interrupt-driven receive does (RXCIE0,
     * which the bootloader, polling, never sets). */
    return true;
  }
  return since_power_up >= sim_ms(BOOT_WINDOW_DONE_MS);
}

void servo_reset(servo_t *servo) {
  avr_reset(servo->avr);
  servo->halted = false;
}

void servo_power_cycle(servo_t *servo) {
  servo_reset(servo);
  set_power_on_flag(servo->avr);
}
