/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The bootloader ELF (firmware/boot, docs/bootloader.md) beside the application in simavr, on
 * both parts (ATmega88 and ATmega328P, boot section 0x1E00 and 0x7E00), a master on the
 * simulated wire: the application starts after the bootloader's check; it enters the
 * bootloader on instruction 0x0A "BOOT" (and not while a store of its settings is under way),
 * which stops the motor; an update page by page to the other profile and back on a bus of
 * three while the other two answer; a power cut after every page write leaves a servo that
 * answers in its bootloader (or, after the last write, runs the new application) and takes a
 * new update; the stock '#' trigger at 57 142 bps; the ID and Baud Rate from the settings
 * (factory values on a blank EEPROM); every error answer, the gap rule, a long packet, the
 * flasher's bytes that end a packet taken up from a cut one, packets to others; the
 * application answering at once after GO that ends a long stay. Simulated time throughout.
 * The applications: the product's, AX12_FIRMWARE_DIR/ax12-<profile>-<mcu>.elf. */
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
#include "boot_protocol.h"
#include "sim_harness.h"

typedef struct {
  const char *mcu;
  uint32_t flash_bytes;
  uint16_t page_bytes;
  uint8_t signature[3];
} part_t;

static const part_t ATMEGA88 = {"atmega88", 8192, 64, {0x1E, 0x93, 0x0A}};
static const part_t ATMEGA328P = {"atmega328p", 32768, 128, {0x1E, 0x95, 0x0F}};

#define MAX_FLASH 32768u
#define MAX_PAGE 128u
#define INFO_REPLY_BYTES (6u + BOOT_INFO_BYTES)
#define STATUS_BYTES 6u
#define PAGE_ANSWER_BYTES (STATUS_BYTES + BOOT_PAGE_HEAD_BYTES) /* the address carried back */
#define BOOT_KEY 'B', 'O', 'O', 'T'
#define HASH_BAUD_REGISTER 34u

/* The bus of three: servo 2 is updated, 1 and 3 keep answering. */
#define OTHER_ID_1 1u
#define UPDATED_ID 2u
#define OTHER_ID_3 3u
#define UPDATED_INDEX 1u

/* ATmega88/328P data addresses. */
#define PORTD_ADDR 0x2Bu
#define TCCR0A_ADDR 0x44u

static uint16_t boot_start_of(const part_t *part) { return boot_section_start(part->flash_bytes); }

static const char *boot_elf(const part_t *part) {
  static char path[1024];
  snprintf(path, sizeof path, "%s/ax12-boot-%s.elf", AX12_FIRMWARE_DIR, part->mcu);
  return path;
}

static const char *app_elf(const part_t *part, const char *profile) {
  static char path[1024];
  snprintf(path, sizeof path, "%s/ax12-%s-%s.elf", AX12_FIRMWARE_DIR, profile, part->mcu);
  return path;
}

/* An application image as the flasher writes it. */
typedef struct {
  uint8_t bytes[MAX_FLASH]; /* the application area as the update leaves it: image, 0xFF, record */
  uint32_t length;
} app_image_t;

static app_image_t *load_image(const part_t *part, const char *profile) {
  app_image_t *image = malloc(sizeof *image);
  assert_non_null(image);
  elf_firmware_t fw;
  memset(&fw, 0, sizeof fw);
  assert_int_equal(elf_read_firmware(app_elf(part, profile), &fw), 0);
  const uint16_t record_at = boot_record_address(boot_start_of(part));
  assert_true(fw.flashsize > 0 && fw.flashsize <= record_at);
  memset(image->bytes, 0xFF, sizeof image->bytes);
  memcpy(image->bytes, fw.flash, fw.flashsize);
  image->length = fw.flashsize;
  boot_record_build(&image->bytes[record_at], image->length, boot_check_bytes(0, image->bytes, image->length));
  free(fw.flash);
  return image;
}

static void open_bus(harness_t *h, const part_t *part, const char *profile, const char *state_dir) {
  harness_open_elf(h, app_elf(part, profile), profile, part->mcu, 1);
  char err[512];
  if (!world_set_bootloader(h->world, boot_elf(part), err, sizeof err)) {
    fail_msg("%s", err);
  }
  harness_add_servo(h, OTHER_ID_1, 1, state_dir);
  harness_add_servo(h, UPDATED_ID, 1, state_dir);
  harness_add_servo(h, OTHER_ID_3, 1, state_dir);
  harness_boot(h, 100);
}

static servo_t *updated_servo(const harness_t *h) { return h->world->servos[UPDATED_INDEX]; }

/* A request; returns the error byte of the status packet (which must come, reply_len long,
 * from id). */
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

/* INFO, answered by the bootloader: its version and the MCU's signature. */
static void assert_bootloader(harness_t *h, const part_t *part, uint8_t id) {
  uint8_t reply[INFO_REPLY_BYTES];
  assert_int_equal(ask(h, id, BOOT_INST_INFO, H_NO_PARAMS, INFO_REPLY_BYTES, reply), 0);
  const uint8_t info[BOOT_INFO_BYTES] = {BOOT_VERSION, part->signature[0], part->signature[1], part->signature[2]};
  assert_memory_equal(&reply[5], info, sizeof info);
}

/* The application answers BOOT, then (no store under way) jumps to the bootloader; asked as
 * the flasher asks: INFO every millisecond until the bootloader answers it, for 20 ms. Returns
 * the milliseconds that took, 0 when the application still answers. */
static unsigned try_enter_bootloader(harness_t *h, uint8_t id) {
  /* Answered like a PING: no Instruction Error (conditions such as Overload may show). */
  assert_int_equal(ask(h, id, BOOT_INST_ENTER, HP(BOOT_KEY), STATUS_BYTES, NULL) & 0x40, 0);
  uint8_t reply[INFO_REPLY_BYTES];
  for (unsigned ms = 1; ms <= 20; ms++) {
    world_run_until(h->world, h->world->now + sim_ms(1));
    const size_t got = harness_request(h, id, BOOT_INST_INFO, H_NO_PARAMS, INFO_REPLY_BYTES, reply);
    if (got == INFO_REPLY_BYTES) {
      return ms;
    }
    assert_int_equal(got, STATUS_BYTES); /* the application: Instruction Error (and any condition) */
    assert_true(reply[4] & 0x40);
  }
  return 0;
}

static unsigned enter_bootloader(harness_t *h, uint8_t id) {
  const unsigned ms = try_enter_bootloader(h, id);
  if (ms == 0) {
    fail_msg("servo %u: no bootloader 20 ms after instruction 0x0A", id);
  }
  return ms;
}

static uint8_t send_page(harness_t *h, const part_t *part, uint16_t address, const uint8_t *data) {
  uint8_t params[BOOT_PAGE_HEAD_BYTES + MAX_PAGE];
  params[0] = (uint8_t)address;
  params[1] = (uint8_t)(address >> 8);
  memcpy(&params[2], data, part->page_bytes);
  uint8_t reply[PAGE_ANSWER_BYTES];
  const uint8_t error =
      ask(h, UPDATED_ID, BOOT_INST_PAGE, params, BOOT_PAGE_HEAD_BYTES + part->page_bytes, PAGE_ANSWER_BYTES, reply);
  assert_memory_equal(&reply[5], params, BOOT_PAGE_HEAD_BYTES); /* the address as sent */
  return error;
}

static void read_page(harness_t *h, const part_t *part, uint16_t address, uint8_t *out) {
  uint8_t reply[6u + MAX_PAGE];
  assert_int_equal(ask(h, UPDATED_ID, BOOT_INST_READ, HP((uint8_t)address, (uint8_t)(address >> 8)),
                       6u + part->page_bytes, reply),
                   0);
  memcpy(out, &reply[5], part->page_bytes);
}

/* The page writes of an update, in the flasher's order (python/ax12_app_image.py
 * update_pages): the record's page with the record erased, the image's other pages, the
 * record's page with the record. */
#define MAX_WRITES (MAX_FLASH / 64u + 2u)
typedef struct {
  uint16_t address[MAX_WRITES];
  uint8_t data[MAX_WRITES][MAX_PAGE];
  unsigned count;
} update_plan_t;

static update_plan_t *plan_update(const part_t *part, const app_image_t *image) {
  update_plan_t *plan = calloc(1, sizeof *plan);
  assert_non_null(plan);
  const uint16_t page = part->page_bytes;
  const uint16_t record_at = boot_record_address(boot_start_of(part));
  const uint16_t record_page = (uint16_t)(record_at - record_at % page);
  plan->address[0] = record_page;
  memcpy(plan->data[0], &image->bytes[record_page], page);
  memset(&plan->data[0][record_at - record_page], 0xFF, BOOT_RECORD_BYTES);
  plan->count = 1;
  for (uint32_t address = 0; address < image->length; address += page) {
    if (address != record_page) {
      plan->address[plan->count] = (uint16_t)address;
      memcpy(plan->data[plan->count++], &image->bytes[address], page);
    }
  }
  plan->address[plan->count] = record_page;
  memcpy(plan->data[plan->count++], &image->bytes[record_page], page);
  return plan;
}

/* Every write of the plan (checking, every 16th, that the other servos still answer), every
 * page read back, GO, the application's power-up. Returns the simulated milliseconds from the
 * first write to GO's answer. */
static double update(harness_t *h, const part_t *part, const update_plan_t *plan) {
  const sim_cycles_t start = h->world->now;
  for (unsigned i = 0; i < plan->count; i++) {
    assert_int_equal(send_page(h, part, plan->address[i], plan->data[i]), 0);
    if (i % 16u == 8u) {
      assert_int_equal(ask(h, OTHER_ID_1, 0x01, H_NO_PARAMS, STATUS_BYTES, NULL), 0);
      assert_int_equal(ask(h, OTHER_ID_3, 0x01, H_NO_PARAMS, STATUS_BYTES, NULL), 0);
    }
  }
  uint8_t page[MAX_PAGE];
  for (unsigned i = 1; i < plan->count; i++) { /* the record's page as written last */
    read_page(h, part, plan->address[i], page);
    assert_memory_equal(page, plan->data[i], part->page_bytes);
  }
  assert_int_equal(ask(h, UPDATED_ID, BOOT_INST_GO, H_NO_PARAMS, STATUS_BYTES, NULL), 0);
  const double ms = (double)(h->world->now - start) / (double)sim_ms(1);
  harness_exchange(h, NULL, 0, 0, NULL, 0); /* the application's power-up */
  return ms;
}

static void check_starts_and_enters(const part_t *part) {
  harness_t h;
  open_bus(&h, part, "ax12", NULL);
  assert_int_equal(firmware_version(&h, UPDATED_ID), 1);
  servo_t *const servo = updated_servo(&h);
  assert_true(servo->avr->pc < boot_start_of(part));
  /* From power-up to the application listening: the '#' window (32.8 ms), the check of the
   * application, the application's own start. */
  servo_power_cycle(servo);
  const sim_cycles_t powered_at = h.world->now;
  while (!(servo->avr->pc < boot_start_of(part) && servo_listening(servo))) {
    world_run_until(h.world, h.world->now + sim_us(100));
    assert_true(h.world->now - powered_at < sim_ms(200));
  }
  const double start_ms = (double)(h.world->now - powered_at) / (double)sim_ms(1);
  print_message("%s: the application listens %.1f ms after power-up\n", part->mcu, start_ms);
  assert_true(start_ms > 32.7 && start_ms < 45.0);
  world_run_until(h.world, h.world->now + sim_ms(20));
  assert_int_equal(firmware_version(&h, UPDATED_ID), 1);
  /* The bootloader's INFO is an unknown instruction to the application, as is 0x0A without
   * its key. */
  assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_INFO, H_NO_PARAMS, STATUS_BYTES, NULL), 0x40);
  assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_ENTER, HP('B', 'O', 'O', 'X'), STATUS_BYTES, NULL), 0x40);
  assert_int_equal(firmware_version(&h, UPDATED_ID), 1);
  /* With nothing to store, the bootloader answers 1 ms after the reply, at the servo's ID. */
  assert_int_equal(enter_bootloader(&h, UPDATED_ID), 1);
  assert_true(servo->avr->pc >= boot_start_of(part));
  assert_bootloader(&h, part, UPDATED_ID);
  assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_PING, H_NO_PARAMS, STATUS_BYTES, NULL), 0);
  assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_ENTER, HP(BOOT_KEY), STATUS_BYTES, NULL), 0);
  /* The application's instructions are unknown to the bootloader. */
  assert_int_equal(ask(&h, UPDATED_ID, 0x02, HP(0x00, 0x03), STATUS_BYTES, NULL), 0x40);
  /* GO: the application again. */
  assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_GO, H_NO_PARAMS, STATUS_BYTES, NULL), 0);
  harness_exchange(&h, NULL, 0, 0, NULL, 0);
  assert_int_equal(firmware_version(&h, UPDATED_ID), 1);
  harness_close(&h);
}

static void test_the_application_starts_after_the_check_and_enters_the_bootloader_when_asked(void **state) {
  (void)state;
  check_starts_and_enters(&ATMEGA88);
  check_starts_and_enters(&ATMEGA328P);
}

static void check_update_there_and_back(const part_t *part) {
  char dir[256];
  harness_tempdir(dir, sizeof dir);
  harness_t h;
  open_bus(&h, part, "ax12", dir);
  app_image_t *ax12a = load_image(part, "ax12a");
  app_image_t *ax12 = load_image(part, "ax12");
  update_plan_t *to_ax12a = plan_update(part, ax12a);
  update_plan_t *to_ax12 = plan_update(part, ax12);
  /* A setting the update must keep: Return Delay Time 0. While its store is under way a BOOT
   * is answered and the application stays: asked again, as the flasher does. */
  assert_int_equal(ask(&h, UPDATED_ID, 0x03, HP(0x05, 0x00), STATUS_BYTES, NULL), 0);
  unsigned tries = 1;
  while (try_enter_bootloader(&h, UPDATED_ID) == 0) {
    assert_true(++tries < 5);
  }
  assert_bootloader(&h, part, UPDATED_ID);
  /* The others run their application meanwhile, and hear nothing they answer. */
  assert_int_equal(firmware_version(&h, OTHER_ID_1), 1);
  const double there_ms = update(&h, part, to_ax12a);
  print_message("%s: update to ax12a, %u B in %u page writes, at 1 Mbps: %.1f ms simulated\n", part->mcu,
                ax12a->length, to_ax12a->count, there_ms);
  assert_int_equal(firmware_version(&h, UPDATED_ID), 2);
  uint8_t reply[7];
  assert_int_equal(ask(&h, UPDATED_ID, 0x02, HP(0x05, 0x01), 7, reply), 0);
  assert_int_equal(reply[5], 0); /* its settings survived the update */
  assert_int_equal(firmware_version(&h, OTHER_ID_1), 1);
  assert_int_equal(firmware_version(&h, OTHER_ID_3), 1);
  /* The flash as written: the bootloader's own check says the same. */
  assert_true(boot_app_valid(updated_servo(&h)->avr->flash, part->flash_bytes));
  assert_memory_equal(updated_servo(&h)->avr->flash, ax12a->bytes, boot_start_of(part));

  assert_int_equal(enter_bootloader(&h, UPDATED_ID), 1);
  const double back_ms = update(&h, part, to_ax12);
  print_message("%s: update back to ax12: %.1f ms simulated\n", part->mcu, back_ms);
  assert_int_equal(firmware_version(&h, UPDATED_ID), 1);
  assert_int_equal(firmware_version(&h, OTHER_ID_1), 1);
  assert_int_equal(firmware_version(&h, OTHER_ID_3), 1);
  free(to_ax12a);
  free(to_ax12);
  free(ax12a);
  free(ax12);
  harness_close(&h);
  harness_rmdir(dir);
}

static void test_an_update_to_ax12a_and_back_on_a_bus_of_three(void **state) {
  (void)state;
  check_update_there_and_back(&ATMEGA88);
  check_update_there_and_back(&ATMEGA328P);
}

/* A power cut after each page write of an update, in turn. After the power comes back the
 * servo stays in its bootloader, answering at its ID (GO leaves it there), and takes the next
 * write; after the last write the new application runs. At three of the cuts a whole new
 * update follows, then the interrupted one is taken up again. */
static void check_cuts(const part_t *part) {
  app_image_t *ax12a = load_image(part, "ax12a");
  update_plan_t *plan = plan_update(part, ax12a);
  harness_t h;
  open_bus(&h, part, "ax12", NULL);
  enter_bootloader(&h, UPDATED_ID);
  unsigned updates = 0;
  for (unsigned cut = 1; cut <= plan->count; cut++) {
    assert_int_equal(send_page(&h, part, plan->address[cut - 1u], plan->data[cut - 1u]), 0);
    harness_power_cycle(&h);
    assert_int_equal(firmware_version(&h, OTHER_ID_1), 1);
    if (cut == plan->count) {
      assert_int_equal(firmware_version(&h, UPDATED_ID), 2); /* whole: the new application runs */
      break;
    }
    assert_true(updated_servo(&h)->avr->pc >= boot_start_of(part));
    assert_false(boot_app_valid(updated_servo(&h)->avr->flash, part->flash_bytes));
    assert_bootloader(&h, part, UPDATED_ID);
    assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_PING, H_NO_PARAMS, STATUS_BYTES, NULL), 0);
    assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_GO, H_NO_PARAMS, STATUS_BYTES, NULL), 0);
    assert_bootloader(&h, part, UPDATED_ID); /* GO: not valid, it stays */
    if (cut == 1u || cut == plan->count / 2u || cut == plan->count - 1u) {
      update(&h, part, plan);
      assert_int_equal(firmware_version(&h, UPDATED_ID), 2);
      updates++;
      enter_bootloader(&h, UPDATED_ID);
      for (unsigned i = 0; i < cut; i++) { /* back where the cut left it */
        assert_int_equal(send_page(&h, part, plan->address[i], plan->data[i]), 0);
      }
    }
  }
  assert_int_equal(updates, 3);
  print_message("%s: a cut after each of %u page writes, each followed by a power-up\n", part->mcu, plan->count);
  free(plan);
  free(ax12a);
  harness_close(&h);
}

static void test_a_cut_after_any_page_write_leaves_a_servo_that_takes_a_new_update(void **state) {
  (void)state;
  check_cuts(&ATMEGA88);
  check_cuts(&ATMEGA328P);
}

/* The stock trigger: '#' at 57 142 bps within the window after power-up keeps the bootloader,
 * at that baud; without it the application starts. */
static void check_hash(const part_t *part) {
  harness_t h;
  open_bus(&h, part, "ax12", NULL);
  master_set_baud_reg(h.master, HASH_BAUD_REGISTER);
  for (size_t i = 0; i < h.world->servo_count; i++) {
    if (i != 2u) { /* servo 3 powers up alone, later */
      servo_power_cycle(h.world->servos[i]);
    }
  }
  const uint8_t hashes[] = {'#', '#', '#', '#'};
  harness_exchange(&h, hashes, sizeof hashes, 0, NULL, 0);
  assert_bootloader(&h, part, UPDATED_ID);
  assert_bootloader(&h, part, OTHER_ID_1);
  assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_GO, H_NO_PARAMS, STATUS_BYTES, NULL), 0);
  master_set_baud_reg(h.master, 1);
  harness_exchange(&h, NULL, 0, 0, NULL, 0);
  assert_int_equal(firmware_version(&h, UPDATED_ID), 1);
  assert_int_equal(firmware_version(&h, OTHER_ID_3), 1);
  /* Servo 1 still waits in its bootloader at 57 142 bps. */
  assert_int_equal(harness_request(&h, OTHER_ID_1, 0x01, H_NO_PARAMS, 0, NULL), 0);
  master_set_baud_reg(h.master, HASH_BAUD_REGISTER);
  assert_int_equal(ask(&h, OTHER_ID_1, 0x01, H_NO_PARAMS, STATUS_BYTES, NULL), 0);
  /* One '#', or two with another byte between, within the window: the application starts. */
  servo_t *const servo = updated_servo(&h);
  const uint8_t not_twice[] = {'#', 'x', '#'};
  for (unsigned round = 0; round < 2; round++) {
    servo_power_cycle(servo);
    harness_exchange(&h, not_twice, round == 0 ? 1u : sizeof not_twice, 0, NULL, 0);
    world_run_until(h.world, h.world->now + sim_ms(60));
    assert_true(servo->avr->pc < boot_start_of(part));
  }
  harness_close(&h);
}

static void test_hash_at_57600_during_power_up_keeps_the_bootloader(void **state) {
  (void)state;
  check_hash(&ATMEGA88);
  check_hash(&ATMEGA328P);
}

/* A WRITE of one byte; its status packet comes from whichever ID (a WRITE of the ID). */
static void write_byte(harness_t *h, uint8_t id, uint8_t address, uint8_t value) {
  uint8_t reply[STATUS_BYTES];
  assert_int_equal(harness_request(h, id, 0x03, HP(address, value), STATUS_BYTES, reply), STATUS_BYTES);
  assert_int_equal(reply[4], 0);
}

/* The bootloader listens at the ID and Baud Rate of the settings, whichever slot the firmware
 * wrote last, and at ID 1 and 1 Mbps on a blank EEPROM. */
static void check_settings(const part_t *part) {
  harness_t h;
  harness_open_elf(&h, app_elf(part, "ax12"), "ax12", part->mcu, 3);
  char err[512];
  if (!world_set_bootloader(h.world, boot_elf(part), err, sizeof err)) {
    fail_msg("%s", err);
  }
  harness_add_servo(&h, 7, 3, NULL); /* ID 7 at 500 kbps */
  uint8_t blank[512];
  memset(blank, 0xFF, sizeof blank);
  servo_t *const fresh = world_add_servo_with_eeprom(h.world, "servo-fresh", blank, sizeof blank, err, sizeof err);
  assert_non_null(fresh);
  fresh->avr->flash[boot_record_address(boot_start_of(part))] ^= 0x01u; /* its application is not valid */
  harness_boot(&h, 100);
  /* Two stores, each in the slot the other does not use: ID 9, then ID 10. */
  write_byte(&h, 7, 3, 9);
  world_run_until(h.world, h.world->now + sim_ms(150));
  write_byte(&h, 9, 3, 10);
  world_run_until(h.world, h.world->now + sim_ms(150));
  servo_t *const servo = h.world->servos[0];
  servo->avr->flash[boot_record_address(boot_start_of(part))] ^= 0x01u;
  harness_power_cycle(&h);
  assert_true(servo->avr->pc >= boot_start_of(part));
  assert_bootloader(&h, part, 10);
  assert_int_equal(harness_request(&h, 9, BOOT_INST_PING, H_NO_PARAMS, 0, NULL), 0);
  assert_int_equal(harness_request(&h, 7, BOOT_INST_PING, H_NO_PARAMS, 0, NULL), 0);
  /* The blank one: ID 1 at 1 Mbps, not at 500 kbps. */
  assert_true(fresh->avr->pc >= boot_start_of(part));
  assert_int_equal(harness_request(&h, 1, BOOT_INST_PING, H_NO_PARAMS, 0, NULL), 0);
  master_set_baud_reg(h.master, 1);
  assert_bootloader(&h, part, 1);
  harness_close(&h);
}

static void test_the_bootloader_answers_at_the_id_and_baud_rate_of_the_settings(void **state) {
  (void)state;
  check_settings(&ATMEGA88);
  check_settings(&ATMEGA328P);
}

/* Wrong requests get their error bit, and the flash stays as it was; packets to other IDs,
 * broadcast, with a bad checksum or a LENGTH below 2 get nothing; a packet cut by a gap of
 * more than 100 ms is dropped, one whose bytes come closer together is taken. */
static void check_bad_requests(const part_t *part) {
  harness_t h;
  open_bus(&h, part, "ax12", NULL);
  enter_bootloader(&h, UPDATED_ID);
  const uint16_t boot_start = boot_start_of(part);
  uint8_t *const flash = updated_servo(&h)->avr->flash;
  uint8_t before[MAX_FLASH];
  memcpy(before, flash, part->flash_bytes);
  uint8_t params[BOOT_PAGE_HEAD_BYTES + MAX_PAGE];
  memset(params, 0x00, sizeof params);
  /* Unknown instructions, and PAGE and READ of the wrong length. */
  assert_int_equal(ask(&h, UPDATED_ID, 0x21, H_NO_PARAMS, STATUS_BYTES, NULL), BOOT_ERROR_INSTRUCTION);
  assert_int_equal(ask(&h, UPDATED_ID, 0x03, HP(0x1E, 0x00, 0x02), STATUS_BYTES, NULL), BOOT_ERROR_INSTRUCTION);
  assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_PAGE, params, BOOT_PAGE_HEAD_BYTES + part->page_bytes - 1u,
                       PAGE_ANSWER_BYTES, NULL),
                   BOOT_ERROR_INSTRUCTION);
  /* One byte longer: framed by its LENGTH all the same, and the wrong length for a PAGE. */
  assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_PAGE, params, BOOT_PAGE_HEAD_BYTES + part->page_bytes + 1u,
                       PAGE_ANSWER_BYTES, NULL),
                   BOOT_ERROR_INSTRUCTION);
  assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_READ, HP(0x00), STATUS_BYTES, NULL), BOOT_ERROR_INSTRUCTION);
  assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_READ, HP(0x00, 0x00, 0x00), STATUS_BYTES, NULL),
                   BOOT_ERROR_INSTRUCTION);
  /* Pages of the boot section, or beyond: Range Error, nothing written or read. */
  const uint16_t outside[] = {boot_start, (uint16_t)(boot_start + part->page_bytes * 2u), 0xFFC0u};
  for (size_t i = 0; i < sizeof outside / sizeof outside[0]; i++) {
    params[0] = (uint8_t)outside[i];
    params[1] = (uint8_t)(outside[i] >> 8);
    assert_int_equal(send_page(&h, part, outside[i], &params[2]), BOOT_ERROR_RANGE);
    assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_READ, params, 2, STATUS_BYTES, NULL), BOOT_ERROR_RANGE);
  }
  assert_memory_equal(flash, before, part->flash_bytes);
  /* An address inside a page names that page. */
  uint8_t page[MAX_PAGE];
  uint8_t reply[6u + MAX_PAGE];
  assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_READ, HP(0x05, 0x01), 6u + part->page_bytes, reply), 0);
  assert_memory_equal(&reply[5], &before[0x100], part->page_bytes);
  for (unsigned i = 0; i < part->page_bytes; i++) {
    page[i] = (uint8_t)(i * 3u);
  }
  assert_int_equal(send_page(&h, part, (uint16_t)(part->page_bytes + 7u), page), 0);
  assert_memory_equal(&flash[part->page_bytes], page, part->page_bytes);
  memcpy(&before[part->page_bytes], page, part->page_bytes);
  /* Nothing for others, broadcast, a bad checksum or a LENGTH below 2 (the applications of
   * servos 1 and 3 answer none of these either). */
  assert_int_equal(harness_request(&h, 0xFE, BOOT_INST_INFO, H_NO_PARAMS, 0, NULL), 0);
  assert_int_equal(harness_request(&h, 0x05, BOOT_INST_INFO, H_NO_PARAMS, 0, NULL), 0);
  const uint8_t bad_sum[] = {0xFF, 0xFF, UPDATED_ID, 0x02, BOOT_INST_PING, 0x00};
  assert_int_equal(harness_exchange(&h, bad_sum, sizeof bad_sum, 0, NULL, 0), 0);
  const uint8_t short_length[] = {0xFF, 0xFF, UPDATED_ID, 0x01, 0xFC, 0xFF, 0xFF, 0xFE, 0x00};
  assert_int_equal(harness_exchange(&h, short_length, sizeof short_length, 0, NULL, 0), 0);
  assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_PING, H_NO_PARAMS, STATUS_BYTES, NULL), 0);
  /* A header of LENGTH 255 and 3 bytes of its body (bytes of a cut packet taken up), then at
   * once the flasher's 256 bytes of 0x00 (python/ax12_boot_client.py FLUSH) and a PING:
   * answered. With 4 fewer than the packet still wants, the PING is taken for its rest. */
  const uint8_t ping_now[] = {0xFF, 0xFF, UPDATED_ID, 0x02, BOOT_INST_PING, (uint8_t)~(UPDATED_ID + 0x02 + 0x01)};
  const unsigned flushes[] = {256u, 255u - 3u - 4u};
  for (size_t f = 0; f < 2; f++) {
    const unsigned flush = flushes[f];
    uint8_t burst[7u + 256u + sizeof ping_now];
    const uint8_t cut[] = {0xFF, 0xFF, UPDATED_ID, 0xFF, BOOT_INST_PAGE, 0x00, 0x01};
    memcpy(burst, cut, sizeof cut);
    memset(&burst[sizeof cut], 0x00, flush);
    memcpy(&burst[sizeof cut + flush], ping_now, sizeof ping_now);
    const size_t expect = f == 0 ? STATUS_BYTES : 0u;
    assert_int_equal(harness_exchange(&h, burst, sizeof cut + flush + sizeof ping_now, expect, reply, sizeof reply),
                     expect);
    if (expect) {
      assert_memory_equal(reply, ((const uint8_t[]){0xFF, 0xFF, UPDATED_ID, 0x02, 0x00}), 5);
    }
  }
  world_run_until(h.world, h.world->now + sim_ms(11)); /* the gap ends the rest */
  /* A PING cut after its LENGTH: 101 ms later a whole PING is answered; the rest of the cut
   * one 50 ms later completes it. */
  const uint8_t ping[] = {0xFF, 0xFF, UPDATED_ID, 0x02, BOOT_INST_PING, (uint8_t)~(UPDATED_ID + 0x02 + 0x01)};
  assert_int_equal(harness_exchange(&h, ping, 4, 0, NULL, 0), 0);
  world_run_until(h.world, h.world->now + sim_ms(11)); /* 90 ms of silence already passed */
  assert_int_equal(harness_exchange(&h, ping, sizeof ping, STATUS_BYTES, reply, sizeof reply), STATUS_BYTES);
  assert_int_equal(harness_exchange(&h, ping, 4, 0, NULL, 0), 0);
  assert_int_equal(harness_exchange(&h, &ping[4], 2, STATUS_BYTES, reply, sizeof reply), STATUS_BYTES);
  assert_int_equal(reply[2], UPDATED_ID);
  assert_memory_equal(flash, before, part->flash_bytes);
  harness_close(&h);
}

static void test_bad_requests_get_their_error_and_packets_to_others_nothing(void **state) {
  (void)state;
  check_bad_requests(&ATMEGA88);
  check_bad_requests(&ATMEGA328P);
}

/* BOOT while a store of the settings is under way is answered, and the application stays;
 * asked again once it is done, it enters. The motor stops in the bootloader. */
static void check_enter_after_store_and_motor(const part_t *part) {
  harness_t h;
  open_bus(&h, part, "ax12", NULL);
  /* Torque on, a goal far away: the motor drives. */
  assert_int_equal(ask(&h, UPDATED_ID, 0x03, HP(0x1E, 0x00, 0x00, 0x00, 0x02), STATUS_BYTES, NULL), 0);
  assert_int_equal(ask(&h, UPDATED_ID, 0x03, HP(0x18, 0x01), STATUS_BYTES, NULL), 0);
  world_run_until(h.world, h.world->now + sim_ms(20));
  servo_t *const servo = updated_servo(&h);
  assert_int_not_equal(servo->avr->data[TCCR0A_ADDR] & 0xF0u, 0); /* a PWM output on */
  /* A store (Return Delay Time and the Alarm LED), then BOOT at once: the application stays. */
  assert_int_equal(ask(&h, UPDATED_ID, 0x03, HP(0x05, 0x10), STATUS_BYTES, NULL), 0);
  assert_int_equal(ask(&h, UPDATED_ID, 0x03, HP(0x11, 0x05), STATUS_BYTES, NULL), 0);
  assert_int_equal(try_enter_bootloader(&h, UPDATED_ID), 0);
  assert_true(servo->avr->pc < boot_start_of(part));
  assert_int_equal(enter_bootloader(&h, UPDATED_ID), 1);
  assert_int_equal(servo->avr->data[TCCR0A_ADDR], 0);                   /* Timer0's outputs off */
  assert_int_equal(servo->avr->data[PORTD_ADDR] & ((1u << 5) | (1u << 6)), 0); /* both bridge inputs low */
  /* The store was whole: after a power cut the settings read back. */
  harness_power_cycle(&h);
  uint8_t reply[7];
  assert_int_equal(ask(&h, UPDATED_ID, 0x02, HP(0x05, 0x01), 7, reply), 0);
  assert_int_equal(reply[5], 0x10);
  assert_int_equal(ask(&h, UPDATED_ID, 0x02, HP(0x11, 0x01), 7, reply), 0);
  assert_int_equal(reply[5], 0x05);
  harness_close(&h);
}

static void test_the_application_enters_once_no_store_is_under_way_and_the_motor_stops(void **state) {
  (void)state;
  check_enter_after_store_and_motor(&ATMEGA88);
  check_enter_after_store_and_motor(&ATMEGA328P);
}

/* A long stay in the bootloader entered from the application (whose Timer1 interrupts stay
 * enabled, the bootloader's interrupts off): every gap of more than 100 ms lets Timer1 pass its
 * compare values. Then GO with a PING right behind it (its bytes arrive while the application
 * sets up its USART, and may start a packet whose LENGTH takes in what follows: docs/policy.md
 * "Framing and bus"): the application answers that PING's next try after the 100 ms gap. */
static void check_long_stay(const part_t *part) {
  harness_t h;
  open_bus(&h, part, "ax12", NULL);
  enter_bootloader(&h, UPDATED_ID);
  for (unsigned gap = 0; gap < 80; gap++) {
    assert_int_equal(ask(&h, UPDATED_ID, BOOT_INST_PING, H_NO_PARAMS, STATUS_BYTES, NULL), 0);
    world_run_until(h.world, h.world->now + sim_ms(150));
  }
  const uint8_t go[] = {0xFF, 0xFF, UPDATED_ID, 0x02, BOOT_INST_GO, (uint8_t)~(UPDATED_ID + 0x02 + BOOT_INST_GO)};
  const uint8_t ping[] = {0xFF, 0xFF, UPDATED_ID, 0x02, 0x01, (uint8_t)~(UPDATED_ID + 0x02 + 0x01)};
  uint8_t reply[16];
  assert_int_equal(harness_exchange(&h, go, sizeof go, STATUS_BYTES, reply, sizeof reply), STATUS_BYTES);
  harness_exchange(&h, ping, sizeof ping, 0, NULL, 0); /* during the application's start */
  world_run_until(h.world, h.world->now + sim_ms(110));
  assert_int_equal(harness_exchange(&h, ping, sizeof ping, STATUS_BYTES, reply, sizeof reply), STATUS_BYTES);
  assert_int_equal(firmware_version(&h, UPDATED_ID), 1);
  harness_close(&h);
}

static void test_the_application_answers_after_a_long_stay_in_the_bootloader(void **state) {
  (void)state;
  check_long_stay(&ATMEGA88);
  check_long_stay(&ATMEGA328P);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_the_application_starts_after_the_check_and_enters_the_bootloader_when_asked),
      cmocka_unit_test(test_an_update_to_ax12a_and_back_on_a_bus_of_three),
      cmocka_unit_test(test_a_cut_after_any_page_write_leaves_a_servo_that_takes_a_new_update),
      cmocka_unit_test(test_hash_at_57600_during_power_up_keeps_the_bootloader),
      cmocka_unit_test(test_the_bootloader_answers_at_the_id_and_baud_rate_of_the_settings),
      cmocka_unit_test(test_bad_requests_get_their_error_and_packets_to_others_nothing),
      cmocka_unit_test(test_the_application_enters_once_no_store_is_under_way_and_the_motor_stops),
      cmocka_unit_test(test_the_application_answers_after_a_long_stay_in_the_bootloader),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
