/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A servo whose flash holds a bootloader beside the application (model/simavr/servo_boot.c)
 * and changes its flash with SPM (servo_flash.c), through simavr, with two small programs
 * instead of the firmware: fw/boot_spm.c at the boot section (0x7E00, the top 512 B), which
 * erases and writes one page, and fw/boot_app.c built twice (two builds of one application).
 * Checks: every reset starts at 0x7E00; the application record is boot_record_build with the
 * check value of the application's bytes; SPM takes 4 ms per page erase or write with SPMEN
 * and RWWSB as on silicon; the flash reaches servo-<n>.flash at the end of the step of the
 * write, survives destroying and recreating the servo, and is dropped (the file removed) when
 * the application is another build or the file is not a flash image; SPM from below the boot
 * section does nothing. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmocka.h>

#include <sim_avr.h>
#include <sim_elf.h>

#include "boot_image.h"
#include "flash_store.h"
#include "servo_flash.h"
#include "servo_run.h"
#include "sim_harness.h"

#define FLASH_BYTES 32768u
#define BOOT_START 0x7E00u
#define RECORD_AT 0x7DFCu /* BOOT_START - BOOT_RECORD_BYTES */
#define PAGE_BYTES 128u
#define TEST_PAGE 0x1000u /* fw/boot_spm.c */
/* ATmega328P data addresses of the general-purpose I/O registers (fw/boot_spm.c reports in
 * them). */
#define GPIOR0_ADDR 0x3Eu
#define GPIOR1_ADDR 0x4Au
#define GPIOR2_ADDR 0x4Bu

static world_t *open_world(const char *app_elf, const char *boot_elf) {
  char err[512];
  world_t *world = world_create(app_elf, "atmega328p", EEPROM_PROFILE_AX12, err, sizeof(err));
  if (!world) {
    fail_msg("%s", err);
  }
  if (boot_elf && !world_set_bootloader(world, boot_elf, err, sizeof(err))) {
    fail_msg("%s", err);
  }
  return world;
}

static servo_t *add_servo(world_t *world, const char *state_path) {
  char err[512];
  servo_t *servo = world_add_servo(world, 1, 1, state_path, err, sizeof(err));
  if (!servo) {
    fail_msg("%s", err);
  }
  return servo;
}

static uint8_t io(const servo_t *servo, unsigned addr) { return servo->avr->data[addr]; }

static bool page_holds_pattern(const uint8_t *page) {
  for (unsigned i = 0; i < PAGE_BYTES; i += 2) {
    if (page[i] != (uint8_t)i || page[i + 1] != 0x5Au) {
      return false;
    }
  }
  return true;
}

static bool file_exists(const char *path) { return access(path, F_OK) == 0; }

/* Runs one instruction of the servo; returns the PC it was at. */
static uint32_t step_one_instruction(servo_t *servo) {
  const uint32_t pc = servo->avr->pc;
  servo->single_step = true;
  servo_run_until(servo, servo->avr->cycle + 1u);
  servo->single_step = false;
  return pc;
}

static void test_every_reset_starts_at_the_boot_section(void **state) {
  (void)state;
  world_t *world = open_world(AX12_BOOT_APP1_ELF, AX12_BOOT_SPM_ELF);
  servo_t *servo = add_servo(world, NULL);
  assert_int_equal(servo->avr->reset_pc, BOOT_START); /* simavr counts it in bytes */
  assert_int_equal(step_one_instruction(servo), BOOT_START);
  assert_true(servo->avr->pc > BOOT_START && servo->avr->pc < FLASH_BYTES); /* the vector's jump, inside */
  world_run_until(world, sim_ms(10));
  assert_int_equal(io(servo, GPIOR0_ADDR), 2); /* the program ran: the page is written */
  servo_reset(servo); /* as the watchdog's */
  assert_int_equal(servo->avr->pc, BOOT_START);
  assert_int_equal(step_one_instruction(servo), BOOT_START);
  servo_power_cycle(servo);
  assert_int_equal(servo->avr->pc, BOOT_START);
  world_run_until(world, world->now + sim_ms(1));
  assert_int_equal(io(servo, GPIOR0_ADDR), 3); /* started again from the boot section: found its page */
  world_destroy(world);
}

static void test_without_a_bootloader_resets_start_at_0_and_no_record_is_written(void **state) {
  (void)state;
  world_t *world = open_world(AX12_BOOT_APP1_ELF, NULL);
  servo_t *servo = add_servo(world, NULL);
  assert_int_equal(servo->avr->reset_pc, 0);
  assert_int_equal(servo->avr->pc, 0);
  for (unsigned i = RECORD_AT; i < FLASH_BYTES; i++) {
    assert_int_equal(servo->avr->flash[i], 0xFF);
  }
  world_run_until(world, sim_ms(1));
  assert_int_equal(io(servo, GPIOR2_ADDR), 1); /* the application ran */
  world_destroy(world);
}

static void test_the_record_is_boot_record_build_with_the_application_bytes_check_value(void **state) {
  (void)state;
  /* The application's bytes as simavr reads its ELF, apart from the emulator's load. */
  elf_firmware_t app;
  memset(&app, 0, sizeof(app));
  assert_int_equal(elf_read_firmware(AX12_BOOT_APP1_ELF, &app), 0);
  assert_true(app.flashsize > 0 && app.flashsize < RECORD_AT);
  uint8_t expected[BOOT_RECORD_BYTES];
  boot_record_build(expected, app.flashsize, boot_check_bytes(0, app.flash, app.flashsize));

  world_t *world = open_world(AX12_BOOT_APP1_ELF, AX12_BOOT_SPM_ELF);
  servo_t *servo = add_servo(world, NULL);
  const uint8_t *flash = servo->avr->flash;
  assert_memory_equal(flash + RECORD_AT, expected, BOOT_RECORD_BYTES);
  for (unsigned i = app.flashsize; i < RECORD_AT; i++) {
    assert_int_equal(flash[i], 0xFF);
  }
  assert_memory_equal(flash, app.flash, app.flashsize);
  uint32_t length = 0;
  uint16_t check = 0;
  assert_true(boot_record_parse(flash + RECORD_AT, BOOT_START, &length, &check));
  assert_int_equal(length, app.flashsize);
  assert_true(boot_app_valid(flash, FLASH_BYTES)); /* valid, as the bootloader checks */
  /* The bootloader's bytes at the boot section (its reset vector: a JMP, 0x940C). */
  assert_int_equal(flash[BOOT_START] | (flash[BOOT_START + 1] << 8), 0x940C);
  world_destroy(world);
  free(app.flash);
  free(app.eeprom);
  free(app.fuse);
  free(app.lockbits);
#if ELF_SYMBOLS
  for (uint32_t i = 0; i < app.symbolcount; i++) {
    free(app.symbol[i]);
  }
  free(app.symbol);
#endif
}

static void test_spm_takes_4_ms_per_page_with_spmen_and_rwwsb_as_on_silicon(void **state) {
  (void)state;
  world_t *world = open_world(AX12_BOOT_APP1_ELF, AX12_BOOT_SPM_ELF);
  servo_t *servo = add_servo(world, NULL);
  world_run_until(world, sim_us(3900));
  assert_int_equal(servo->spm_page_ops, 1);
  assert_int_equal(io(servo, GPIOR0_ADDR), 0); /* the erase is still under way: SPMEN set */
  assert_true(servo->spm_busy);
  world_run_until(world, sim_us(4200));
  assert_int_equal(io(servo, GPIOR0_ADDR), 1);
  world_run_until(world, sim_us(7900));
  assert_int_equal(io(servo, GPIOR0_ADDR), 1); /* the write is under way */
  world_run_until(world, sim_us(8300));
  assert_int_equal(io(servo, GPIOR0_ADDR), 2);
  assert_int_equal(io(servo, GPIOR1_ADDR), 3); /* RWWSB set after the write, cleared by RWWSRE */
  assert_int_equal(servo->spm_page_ops, 2);
  assert_int_equal(servo->spm_ignored, 0);
  assert_true(page_holds_pattern(servo->avr->flash + TEST_PAGE));
  world_destroy(world);
}

static void read_state_flash(const char *path, uint8_t *flash) {
  FILE *f = fopen(path, "rb");
  assert_non_null(f);
  uint8_t header[FLASH_STORE_HEADER_BYTES];
  assert_int_equal(fread(header, 1, sizeof header, f), sizeof header);
  assert_memory_equal(header, "AX12FLSH", 8);
  assert_int_equal(fread(flash, 1, FLASH_BYTES, f), FLASH_BYTES);
  assert_int_equal(fgetc(f), EOF);
  fclose(f);
}

/* A fresh state folder, and the paths of servo 1's EEPROM and flash files in it. */
#define STATE_DIR_BYTES 256u
#define STATE_PATH_BYTES 512u
static void state_paths(char dir[STATE_DIR_BYTES], char eeprom_path[STATE_PATH_BYTES], char flash_path[STATE_PATH_BYTES]) {
  harness_tempdir(dir, STATE_DIR_BYTES);
  snprintf(eeprom_path, STATE_PATH_BYTES, "%s/servo-1.eeprom", dir);
  snprintf(flash_path, STATE_PATH_BYTES, "%s/servo-1.flash", dir);
}

static void test_a_flash_changed_by_spm_is_persisted_kept_and_dropped_for_another_build(void **state) {
  (void)state;
  char dir[STATE_DIR_BYTES], eeprom_path[STATE_PATH_BYTES], flash_path[STATE_PATH_BYTES];
  state_paths(dir, eeprom_path, flash_path);

  world_t *world = open_world(AX12_BOOT_APP1_ELF, AX12_BOOT_SPM_ELF);
  servo_t *servo = add_servo(world, eeprom_path);
  assert_int_equal(servo->flash_origin, SERVO_FLASH_FROM_ELF);
  assert_string_equal(servo->flash_path, flash_path);
  /* The erase of a blank page changes nothing: still no file while the write has not come. */
  world_run_until(world, sim_us(3900));
  assert_int_equal(servo->spm_page_ops, 1);
  assert_false(file_exists(flash_path));
  /* The file holds the written page at the end of the step of the write. */
  while (servo->spm_page_ops < 2) {
    world_run_until(world, world->now + 1u);
  }
  assert_true(file_exists(flash_path));
  static uint8_t stored[FLASH_BYTES];
  read_state_flash(flash_path, stored);
  assert_memory_equal(stored, servo->avr->flash, FLASH_BYTES);
  assert_true(page_holds_pattern(stored + TEST_PAGE));
  world_run_until(world, world->now + sim_ms(5));
  assert_int_equal(io(servo, GPIOR0_ADDR), 2);
  world_destroy(world);

  /* The same build again: the flash as it was left. */
  world = open_world(AX12_BOOT_APP1_ELF, AX12_BOOT_SPM_ELF);
  servo = add_servo(world, eeprom_path);
  assert_int_equal(servo->flash_origin, SERVO_FLASH_FROM_STATE);
  assert_true(page_holds_pattern(servo->avr->flash + TEST_PAGE));
  world_run_until(world, sim_ms(1));
  assert_int_equal(io(servo, GPIOR0_ADDR), 3);
  assert_int_equal(servo->spm_page_ops, 0);
  world_destroy(world);
  assert_true(file_exists(flash_path)); /* a clean end keeps it */

  /* Another build of the application: the flashed image is dropped, the file removed. */
  world = open_world(AX12_BOOT_APP2_ELF, AX12_BOOT_SPM_ELF);
  servo = add_servo(world, eeprom_path);
  assert_int_equal(servo->flash_origin, SERVO_FLASH_DROPPED_OTHER_BUILD);
  assert_false(file_exists(flash_path));
  assert_int_equal(servo->avr->flash[TEST_PAGE], 0xFF);
  world_destroy(world);
  harness_rmdir(dir);
}

static void test_a_flash_file_that_is_no_image_of_the_mcu_is_dropped(void **state) {
  (void)state;
  char dir[STATE_DIR_BYTES], eeprom_path[STATE_PATH_BYTES], flash_path[STATE_PATH_BYTES];
  state_paths(dir, eeprom_path, flash_path);
  FILE *f = fopen(flash_path, "wb");
  assert_non_null(f);
  fputs("AX12FLSH but cut short", f);
  fclose(f);
  world_t *world = open_world(AX12_BOOT_APP1_ELF, AX12_BOOT_SPM_ELF);
  servo_t *servo = add_servo(world, eeprom_path);
  assert_int_equal(servo->flash_origin, SERVO_FLASH_DROPPED_INVALID);
  assert_false(file_exists(flash_path));
  world_destroy(world);
  harness_rmdir(dir);
}

static void test_spm_outside_the_boot_section_does_nothing(void **state) {
  (void)state;
  world_t *world = open_world(AX12_BOOT_APP2_ELF, NULL); /* build 2 writes a page from address 0's section */
  servo_t *servo = add_servo(world, NULL);
  world_run_until(world, sim_ms(1));
  assert_int_equal(io(servo, GPIOR0_ADDR), 1); /* it tried, and SPMEN did not hang it */
  assert_int_equal(servo->spm_page_ops, 0);
  assert_true(servo->spm_ignored >= 1);
  for (unsigned i = 0; i < PAGE_BYTES; i++) {
    assert_int_equal(servo->avr->flash[TEST_PAGE + i], 0xFF);
  }
  world_destroy(world);
}

static void test_a_bootloader_outside_the_boot_section_is_refused(void **state) {
  (void)state;
  char err[512];
  world_t *world = world_create(AX12_BOOT_APP1_ELF, "atmega328p", EEPROM_PROFILE_AX12, err, sizeof(err));
  assert_non_null(world);
  assert_false(world_set_bootloader(world, AX12_BOOT_APP2_ELF, err, sizeof(err)));
  assert_non_null(strstr(err, "not at the boot section's start 0x7e00"));
  world_destroy(world);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_every_reset_starts_at_the_boot_section),
      cmocka_unit_test(test_without_a_bootloader_resets_start_at_0_and_no_record_is_written),
      cmocka_unit_test(test_the_record_is_boot_record_build_with_the_application_bytes_check_value),
      cmocka_unit_test(test_spm_takes_4_ms_per_page_with_spmen_and_rwwsb_as_on_silicon),
      cmocka_unit_test(test_a_flash_changed_by_spm_is_persisted_kept_and_dropped_for_another_build),
      cmocka_unit_test(test_a_flash_file_that_is_no_image_of_the_mcu_is_dropped),
      cmocka_unit_test(test_spm_outside_the_boot_section_does_nothing),
      cmocka_unit_test(test_a_bootloader_outside_the_boot_section_is_refused),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
