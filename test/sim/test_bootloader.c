/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The bootloader ELF (firmware/boot, docs/bootloader.md) beside the application ELF on an
 * ATmega328P in simavr, a master on the simulated wire: the application starts after the
 * bootloader's check; it enters the bootloader on instruction 0x0A "BOOT" while another servo
 * on the bus carries on; an update to the ax12a build page by page, and back; a power cut
 * after BEGIN, after every page and after END leaves a servo that answers (in its bootloader,
 * or after END in the new application) and takes a new update; the stock '#' trigger at
 * 57 142 bps; the settings (ID, baud) kept throughout. Simulated time throughout. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include <sim_avr.h>
#include <sim_elf.h>

#include "boot_image.h"
#include "sim_harness.h"

#define BOOT_ELF AX12_FIRMWARE_DIR "/ax12-boot-atmega328p.elf"
#define PAGE_BYTES 128u
#define BOOT_START 0x7800u
#define RECORD_AT (BOOT_START - PAGE_BYTES)

/* docs/bootloader.md "Packets". */
#define INST_INFO 0x20u
#define INST_BEGIN 0x21u
#define INST_PAGE 0x22u
#define INST_END 0x23u
#define INST_READ 0x24u
#define INST_GO 0x25u
#define INST_BOOT 0x0Au
#define STATE_APP_VALID 0x01u
#define STATE_BY_REQUEST 0x02u
#define STATE_BY_HASH 0x04u
#define INFO_REPLY_BYTES (6u + 13u)
#define BOOT_KEY 'B', 'O', 'O', 'T'

#define UPDATED_ID 2u
#define OTHER_ID 1u

typedef struct {
  uint8_t bytes[BOOT_START];
  uint16_t length;
  uint16_t crc;
} app_image_t;

static void load_image(app_image_t *image, const char *profile) {
  elf_firmware_t fw;
  memset(&fw, 0, sizeof fw);
  assert_int_equal(elf_read_firmware(harness_elf_path(profile, "atmega328p"), &fw), 0);
  assert_true(fw.flashsize > 0 && fw.flashsize < RECORD_AT);
  memset(image->bytes, 0xFF, sizeof image->bytes);
  memcpy(image->bytes, fw.flash, fw.flashsize);
  image->length = (uint16_t)fw.flashsize;
  image->crc = boot_crc_bytes(BOOT_CRC_INITIAL, image->bytes, image->length);
  free(fw.flash);
}

static void open_bus(harness_t *h, const char *state_dir) {
  harness_open(h, "ax12", "atmega328p", 1);
  char err[512];
  if (!world_set_bootloader(h->world, BOOT_ELF, err, sizeof err)) {
    fail_msg("%s", err);
  }
  harness_add_servo(h, OTHER_ID, 1, state_dir);
  harness_add_servo(h, UPDATED_ID, 1, state_dir);
  harness_boot(h, 100);
}

/* A request; returns the error byte of the status packet (which must come, reply_len long). */
static uint8_t ask(harness_t *h, uint8_t id, uint8_t instruction, const uint8_t *params, size_t count,
                   size_t reply_len, uint8_t *reply) {
  uint8_t buffer[HARNESS_MAX_REPLY];
  uint8_t *const out = reply ? reply : buffer;
  const size_t got = harness_request(h, id, instruction, params, count, reply_len, out);
  assert_int_equal(got, reply_len);
  assert_int_equal(out[2], id);
  return out[4];
}

static uint8_t firmware_version(harness_t *h, uint8_t id) {
  uint8_t reply[16];
  assert_int_equal(ask(h, id, 0x02, HP(0x00, 0x03), 9, reply), 0);
  assert_int_equal(reply[5], 12); /* Model Number 12 */
  assert_int_equal(reply[6], 0);
  return reply[7];
}

static uint8_t info_state(harness_t *h, uint8_t id) {
  uint8_t reply[INFO_REPLY_BYTES];
  assert_int_equal(ask(h, id, INST_INFO, H_NO_PARAMS, INFO_REPLY_BYTES, reply), 0);
  const uint8_t head[] = {'A', 'X', 'B', 'L', 1, 0x1E, 0x95, 0x0F, PAGE_BYTES, 0, 0x00, 0x78};
  assert_memory_equal(&reply[5], head, sizeof head);
  return reply[17];
}

/* The application answers, then hands over to the bootloader once any store of its settings
 * under way has finished (3.4 ms a byte, docs/bootloader.md); asked as the flasher asks: INFO
 * every millisecond until it answers. Returns the milliseconds that took. */
static unsigned enter_bootloader(harness_t *h, uint8_t id) {
  assert_int_equal(ask(h, id, INST_BOOT, HP(BOOT_KEY), 6, NULL), 0);
  uint8_t reply[INFO_REPLY_BYTES];
  for (unsigned ms = 1; ms <= 100; ms++) {
    world_run_until(h->world, h->world->now + sim_ms(1));
    if (harness_request(h, id, INST_INFO, H_NO_PARAMS, INFO_REPLY_BYTES, reply) == INFO_REPLY_BYTES) {
      return ms;
    }
  }
  fail_msg("servo %u: no bootloader 100 ms after instruction 0x0A", id);
  return 0;
}

static uint8_t begin(harness_t *h, const app_image_t *image) {
  const uint8_t params[4] = {(uint8_t)image->length, (uint8_t)(image->length >> 8), (uint8_t)image->crc,
                             (uint8_t)(image->crc >> 8)};
  return ask(h, UPDATED_ID, INST_BEGIN, params, 4, 6, NULL);
}

static uint8_t send_page(harness_t *h, const app_image_t *image, uint16_t address) {
  uint8_t params[4u + PAGE_BYTES];
  const uint16_t crc = boot_crc_bytes(BOOT_CRC_INITIAL, &image->bytes[address], PAGE_BYTES);
  params[0] = (uint8_t)address;
  params[1] = (uint8_t)(address >> 8);
  params[2] = (uint8_t)crc;
  params[3] = (uint8_t)(crc >> 8);
  memcpy(&params[4], &image->bytes[address], PAGE_BYTES);
  return ask(h, UPDATED_ID, INST_PAGE, params, sizeof params, 6, NULL);
}

static unsigned page_count(const app_image_t *image) { return (image->length + PAGE_BYTES - 1u) / PAGE_BYTES; }

/* BEGIN, every page, END, a READ of the first page, GO: the flasher's steps. */
static void update(harness_t *h, const app_image_t *image) {
  assert_int_equal(begin(h, image), 0);
  for (unsigned p = 0; p < page_count(image); p++) {
    assert_int_equal(send_page(h, image, (uint16_t)(p * PAGE_BYTES)), 0);
  }
  assert_int_equal(ask(h, UPDATED_ID, INST_END, H_NO_PARAMS, 6, NULL), 0);
  uint8_t reply[6u + PAGE_BYTES];
  assert_int_equal(ask(h, UPDATED_ID, INST_READ, HP(0x00, 0x00), sizeof reply, reply), 0);
  assert_memory_equal(&reply[5], image->bytes, PAGE_BYTES);
  assert_int_equal(ask(h, UPDATED_ID, INST_GO, H_NO_PARAMS, 6, NULL), 0);
  harness_exchange(h, NULL, 0, 0, NULL, 0); /* the application's power-up */
}

static void test_the_application_starts_after_the_check_and_enters_the_bootloader_when_asked(void **state) {
  (void)state;
  harness_t h;
  open_bus(&h, NULL);
  assert_int_equal(firmware_version(&h, UPDATED_ID), 1);
  assert_true(h.world->servos[1]->avr->pc < BOOT_START);
  /* From power-up to the application listening: the '#' window (30 ms) and the check of the
   * application's CRC. */
  servo_t *const servo = h.world->servos[1];
  servo_power_cycle(servo);
  const sim_cycles_t powered_at = h.world->now;
  while (!(servo->avr->pc < BOOT_START && servo_listening(servo))) {
    world_run_until(h.world, h.world->now + sim_us(100));
    assert_true(h.world->now - powered_at < sim_ms(200));
  }
  const double start_ms = (double)(h.world->now - powered_at) / (double)sim_ms(1);
  print_message("the application listens %.1f ms after power-up\n", start_ms);
  assert_true(start_ms > 30.0 && start_ms < 60.0);
  world_run_until(h.world, h.world->now + sim_ms(20));
  assert_int_equal(firmware_version(&h, UPDATED_ID), 1);
  /* The bootloader's INFO is an unknown instruction to the application. */
  assert_int_equal(ask(&h, UPDATED_ID, INST_INFO, H_NO_PARAMS, 6, NULL), 0x40);
  /* As is instruction 0x0A without its key. */
  assert_int_equal(ask(&h, UPDATED_ID, INST_BOOT, HP('B', 'O', 'O', 'X'), 6, NULL), 0x40);
  assert_int_equal(firmware_version(&h, UPDATED_ID), 1);
  /* With nothing to store, the bootloader answers 1 ms after the reply. */
  assert_int_equal(enter_bootloader(&h, UPDATED_ID), 1);
  assert_true(h.world->servos[1]->avr->pc >= BOOT_START);
  harness_close(&h);
}

static void test_an_update_to_ax12a_and_back_on_a_bus_of_two(void **state) {
  (void)state;
  char dir[256];
  harness_tempdir(dir, sizeof dir);
  harness_t h;
  open_bus(&h, dir);
  /* Settings of the servo to update: a Baud Rate the update must keep (and its ID). */
  app_image_t *ax12a = malloc(sizeof *ax12a);
  app_image_t *ax12 = malloc(sizeof *ax12);
  load_image(ax12a, "ax12a");
  load_image(ax12, "ax12");
  assert_int_equal(ask(&h, UPDATED_ID, 0x03, HP(0x05, 0x00), 6, NULL), 0); /* Return Delay Time 0 */

  /* The store of that write (a few bytes) finishes first. */
  assert_in_range(enter_bootloader(&h, UPDATED_ID), 2, 40);
  assert_int_equal(info_state(&h, UPDATED_ID), STATE_BY_REQUEST | STATE_APP_VALID);
  /* The other servo runs its application meanwhile, and hears nothing it answers. */
  assert_int_equal(firmware_version(&h, OTHER_ID), 1);
  const sim_cycles_t start = h.world->now;
  update(&h, ax12a);
  const double update_ms = (double)(h.world->now - start) / (double)sim_ms(1);
  print_message("update of %u bytes (%u pages) at 1 Mbps: %.1f ms simulated\n", ax12a->length,
                page_count(ax12a), update_ms);
  assert_int_equal(firmware_version(&h, UPDATED_ID), 2);
  uint8_t reply[7];
  assert_int_equal(ask(&h, UPDATED_ID, 0x02, HP(0x05, 0x01), 7, reply), 0);
  assert_int_equal(reply[5], 0); /* its settings survived the update */
  assert_int_equal(firmware_version(&h, OTHER_ID), 1);

  enter_bootloader(&h, UPDATED_ID);
  update(&h, ax12);
  assert_int_equal(firmware_version(&h, UPDATED_ID), 1);
  assert_int_equal(firmware_version(&h, OTHER_ID), 1);
  free(ax12a);
  free(ax12);
  harness_close(&h);
  harness_rmdir(dir);
}

/* A cut after BEGIN, after every page, and after END but before GO. After the power comes
 * back the bootloader stays (application not valid, but for the cut after END, whose
 * application is whole), answers at the servo's ID and baud, and a new update completes. */
static void test_a_cut_at_any_moment_of_an_update_leaves_a_servo_that_takes_a_new_one(void **state) {
  (void)state;
  app_image_t *ax12a = malloc(sizeof *ax12a);
  load_image(ax12a, "ax12a");
  const unsigned pages = page_count(ax12a);
  for (unsigned cut = 0; cut <= pages + 1u; cut++) { /* pages written; pages + 1: after END */
    harness_t h;
    open_bus(&h, NULL);
    enter_bootloader(&h, UPDATED_ID);
    assert_int_equal(begin(&h, ax12a), 0);
    for (unsigned p = 0; p < cut && p < pages; p++) {
      assert_int_equal(send_page(&h, ax12a, (uint16_t)(p * PAGE_BYTES)), 0);
    }
    const bool ended = cut > pages;
    if (ended) {
      assert_int_equal(ask(&h, UPDATED_ID, INST_END, H_NO_PARAMS, 6, NULL), 0);
    }
    harness_power_cycle(&h);
    if (ended) {
      assert_int_equal(firmware_version(&h, UPDATED_ID), 2); /* whole: the new application runs */
    } else {
      assert_int_equal(info_state(&h, UPDATED_ID), 0);       /* stays, application not valid */
      assert_int_equal(ask(&h, UPDATED_ID, 0x01, H_NO_PARAMS, 6, NULL), 0);
      assert_int_equal(firmware_version(&h, OTHER_ID), 1);
      update(&h, ax12a);
      assert_int_equal(firmware_version(&h, UPDATED_ID), 2);
    }
    harness_close(&h);
  }
  free(ax12a);
}

/* The stock trigger: '#' at 57 142 bps within 30 ms of power-up keeps the bootloader, at that
 * baud; without it the application starts. */
static void test_hash_at_57600_during_power_up_keeps_the_bootloader(void **state) {
  (void)state;
  harness_t h;
  open_bus(&h, NULL);
  master_set_baud_reg(h.master, 34);
  for (size_t i = 0; i < h.world->servo_count; i++) {
    servo_power_cycle(h.world->servos[i]);
  }
  const uint8_t hashes[] = {'#', '#', '#', '#'};
  harness_exchange(&h, hashes, sizeof hashes, 0, NULL, 0);
  assert_int_equal(info_state(&h, UPDATED_ID), STATE_BY_HASH | STATE_APP_VALID);
  assert_int_equal(info_state(&h, OTHER_ID), STATE_BY_HASH | STATE_APP_VALID);
  assert_int_equal(ask(&h, UPDATED_ID, INST_GO, H_NO_PARAMS, 6, NULL), 0);
  master_set_baud_reg(h.master, 1);
  harness_exchange(&h, NULL, 0, 0, NULL, 0);
  assert_int_equal(firmware_version(&h, UPDATED_ID), 1);
  /* The other one still waits in its bootloader at 57 142 bps. */
  assert_int_equal(harness_request(&h, OTHER_ID, 0x01, H_NO_PARAMS, 0, NULL), 0);
  master_set_baud_reg(h.master, 34);
  assert_int_equal(ask(&h, OTHER_ID, 0x01, H_NO_PARAMS, 6, NULL), 0);
  harness_close(&h);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_the_application_starts_after_the_check_and_enters_the_bootloader_when_asked),
      cmocka_unit_test(test_an_update_to_ax12a_and_back_on_a_bus_of_two),
      cmocka_unit_test(test_a_cut_at_any_moment_of_an_update_leaves_a_servo_that_takes_a_new_one),
      cmocka_unit_test(test_hash_at_57600_during_power_up_keeps_the_bootloader),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
