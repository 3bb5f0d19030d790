/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Power cuts during EEPROM writes, on the firmware ELF in simavr: a servo gets a multi-byte
 * WRITE of its EEPROM area (and a RESET), the EEPROM is captured at every byte the firmware
 * writes (a cut between two bytes) and with that byte torn (a cut in the byte: it reads back
 * as garbage), and a new servo boots from each capture. Each must answer with exactly the
 * settings before the packet or after it (docs/policy.md "Settings"): at the old ID and baud
 * or at the new ones, never a mix, never factory defaults. A second EEPROM WRITE during a
 * store is stored too, and under a stream of EEPROM WRITEs back to back every write is stored
 * within 100 ms while a cut at any byte keeps every write stored before it. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "dxl_image.h"
#include "dxl_protocol.h"
#include "dxl_table.h"
#include "eeprom_store.h"
#include "sim_harness.h"

#define MCU "atmega88"
#define STATUS_LEN(params) (6u + (params))
#define MAX_CAPTURES 64u
#define EEPROM_BYTES 512u
/* Values a torn byte is left at (besides the old and new values of a cut between bytes). */
static const uint8_t torn_values[] = {0x00, 0xFF};

typedef struct {
  uint8_t bytes[MAX_CAPTURES][EEPROM_BYTES];
  size_t written_addr[MAX_CAPTURES]; /* the byte the write of capture k stored (k >= 1) */
  size_t count;                      /* captures[0] is before the packet */
} captures_t;

/* The EEPROM area as a servo at (id, baud) answers it; false when it does not answer. */
static bool read_settings(harness_t *h, uint8_t id, uint8_t area[CT_EEPROM_SIZE]) {
  uint8_t reply[64];
  const size_t n = harness_request(h, id, DXL_INST_READ, HP(0, CT_EEPROM_SIZE), STATUS_LEN(CT_EEPROM_SIZE), reply);
  if (n != STATUS_LEN(CT_EEPROM_SIZE)) {
    return false;
  }
  memcpy(area, &reply[5], CT_EEPROM_SIZE);
  return true;
}

/* After any run of the world: when the firmware has written an EEPROM byte since *writes (one
 * at most: they are 3.4 ms apart), copies the EEPROM to next and returns the address that
 * byte changed (last: the EEPROM before it); EEPROM_BYTES when none was written. */
static size_t captured_write(const servo_t *servo, uint64_t *writes, const uint8_t *last, uint8_t *next) {
  if (servo->eeprom_writes == *writes) {
    return EEPROM_BYTES;
  }
  assert_int_equal(servo->eeprom_writes, *writes + 1u);
  *writes = servo->eeprom_writes;
  memcpy(next, servo->eeprom, EEPROM_BYTES);
  size_t addr = 0;
  while (addr < EEPROM_BYTES && next[addr] == last[addr]) {
    addr++;
  }
  assert_true(addr < EEPROM_BYTES);
  return addr;
}

/* Saves eeprom as servo 1's state file in a new directory (its path to dir). */
static void save_state(char *dir, size_t dir_len, const uint8_t *eeprom) {
  harness_tempdir(dir, dir_len);
  char path[512];
  char err[256];
  eeprom_store_path(path, sizeof path, dir, 1);
  assert_int_equal(eeprom_store_save(path, eeprom, EEPROM_BYTES, err, sizeof err), 0);
}

/* torn: eeprom as a cut in the write of byte k of last (EEPROM address addr) leaves it, the
 * byte at torn_values[t]; what: the cut in words. */
static void tear(const uint8_t *eeprom, size_t addr, size_t t, size_t k, size_t last, uint8_t torn[EEPROM_BYTES],
                 char *what, size_t what_len) {
  memcpy(torn, eeprom, EEPROM_BYTES);
  torn[addr] = torn_values[t];
  snprintf(what, what_len, "cut in EEPROM byte %zu of %zu (EEPROM %zu left at 0x%02X)", k, last, addr, torn_values[t]);
}

/* A servo at ID 1, 1 Mbps, with its state file in dir, booted. */
static servo_t *boot_servo(harness_t *h, const char *dir) {
  harness_open(h, "ax12", MCU, 1);
  servo_t *servo = harness_add_servo(h, 1, 1, dir);
  harness_boot(h, 5);
  return servo;
}

/* A servo at ID 1, 1 Mbps, with a state file in dir: boots, gets the setup packets, then the
 * packet under test, while every byte the firmware writes to its EEPROM is captured. */
static void capture_write(const char *dir, const uint8_t *setup, size_t setup_len, const uint8_t *packet,
                          size_t packet_len, captures_t *c, uint8_t before[CT_EEPROM_SIZE],
                          uint8_t after[CT_EEPROM_SIZE], uint8_t after_id, uint8_t after_baud) {
  harness_t h;
  servo_t *servo = boot_servo(&h, dir);
  uint8_t reply[64];
  if (setup_len) {
    (void)harness_exchange(&h, setup, setup_len, STATUS_LEN(0), reply, sizeof reply);
    world_run_until(h.world, h.world->now + sim_ms(150)); /* stored: both slots hold settings */
  }
  assert_true(read_settings(&h, 1, before));
  memcpy(c->bytes[0], servo->eeprom, EEPROM_BYTES);
  c->count = 1;
  uint64_t writes = servo->eeprom_writes;
  const size_t heard = harness_exchange(&h, packet, packet_len, STATUS_LEN(0), reply, sizeof reply);
  assert_int_equal(heard, STATUS_LEN(0)); /* answered at once, not after the store */
  const sim_cycles_t end = h.world->now + sim_ms(200);
  while (h.world->now < end) {
    world_run_until(h.world, h.world->now + sim_us(20));
    assert_true(c->count < MAX_CAPTURES);
    const size_t addr = captured_write(servo, &writes, c->bytes[c->count - 1u], c->bytes[c->count]);
    if (addr < EEPROM_BYTES) {
      c->written_addr[c->count++] = addr;
    }
  }
  assert_true(c->count > 3u); /* at least a data byte, the check and the sequence number */
  master_set_baud_reg(h.master, after_baud);
  assert_true(read_settings(&h, after_id, after));
  harness_close(&h);
}

/* Boots a servo from eeprom and returns which settings it answers with: 0 the old, 1 the new. */
static int boot_from(const uint8_t *eeprom, const uint8_t before[CT_EEPROM_SIZE], const uint8_t after[CT_EEPROM_SIZE],
                     const char *what) {
  char dir[256];
  save_state(dir, sizeof dir, eeprom);
  int result = -1;
  for (int which = 0; which < 2 && result < 0; which++) {
    /* Asked at the old ID and baud, then at the new ones. */
    const uint8_t *ask = which == 0 ? before : after;
    harness_t h;
    harness_open(&h, "ax12", MCU, ask[CT_ADDR_BAUD_RATE]);
    harness_add_servo(&h, 1, 1, dir);
    harness_boot(&h, 5);
    uint8_t area[CT_EEPROM_SIZE];
    if (read_settings(&h, ask[CT_ADDR_ID], area)) {
      if (memcmp(area, before, CT_EEPROM_SIZE) == 0) {
        result = 0;
      } else if (memcmp(area, after, CT_EEPROM_SIZE) == 0) {
        result = 1;
      } else {
        char got_hex[128];
        char old_hex[128];
        char new_hex[128];
        fail_msg("%s: boots %s, neither the old %s nor the new %s", what,
                 packet_hex(area, CT_EEPROM_SIZE, got_hex, sizeof got_hex),
                 packet_hex(before, CT_EEPROM_SIZE, old_hex, sizeof old_hex),
                 packet_hex(after, CT_EEPROM_SIZE, new_hex, sizeof new_hex));
      }
    }
    harness_close(&h);
  }
  harness_rmdir(dir);
  if (result < 0) {
    fail_msg("%s: answers with neither the old nor the new settings", what);
  }
  return result;
}

/* Every cut of the packet's store: returns how many were tried. */
static unsigned cut_everywhere(const uint8_t *setup, size_t setup_len, const uint8_t *packet, size_t packet_len,
                               uint8_t after_id, uint8_t after_baud) {
  static captures_t c;
  char dir[256];
  harness_tempdir(dir, sizeof dir);
  uint8_t before[CT_EEPROM_SIZE];
  uint8_t after[CT_EEPROM_SIZE];
  capture_write(dir, setup, setup_len, packet, packet_len, &c, before, after, after_id, after_baud);
  harness_rmdir(dir);
  unsigned cuts = 0;
  int last = 0;
  for (size_t k = 0; k < c.count; k++) {
    char what[96];
    snprintf(what, sizeof what, "cut after byte %zu of %zu", k, c.count - 1u);
    const int booted = boot_from(c.bytes[k], before, after, what);
    assert_true(booted >= last); /* once new, new for good */
    last = booted;
    cuts++;
    if (k == 0) {
      continue;
    }
    for (size_t t = 0; t < sizeof torn_values; t++) {
      uint8_t torn[EEPROM_BYTES];
      tear(c.bytes[k], c.written_addr[k], t, k, c.count - 1u, torn, what, sizeof what);
      (void)boot_from(torn, before, after, what);
      cuts++;
    }
  }
  assert_int_equal(last, 1); /* the complete store boots the new settings */
  return cuts;
}

/* A robot's joint renamed and moved to another speed: ID, baud and Return Delay Time in one
 * WRITE, over settings written once before (so both slots hold settings). */
static void test_a_cut_anywhere_in_a_write_of_id_baud_and_delay_boots_old_or_new(void **state) {
  (void)state;
  uint8_t setup[16];
  uint8_t packet[16];
  const size_t setup_len = packet_encode(setup, 1, DXL_INST_WRITE, HP(CT_ADDR_RETURN_DELAY_TIME, 10));
  const size_t packet_len = packet_encode(packet, 1, DXL_INST_WRITE, HP(CT_ADDR_ID, 8, 16, 100));
  const unsigned cuts = cut_everywhere(setup, setup_len, packet, packet_len, 8, 16);
  print_message("%u cuts, 0 failures\n", cuts);
}

/* Eight bytes across the limits and alarms (addresses 11..18), a 16-bit item among them. */
static void test_a_cut_anywhere_in_an_eight_byte_write_boots_old_or_new(void **state) {
  (void)state;
  uint8_t packet[32];
  const size_t packet_len =
      packet_encode(packet, 1, DXL_INST_WRITE, HP(CT_ADDR_HIGHEST_LIMIT_TEMP, 80, 55, 150, 0x00, 0x02, 1, 0x25, 0x25));
  const unsigned cuts = cut_everywhere(NULL, 0, packet, packet_len, 1, 1);
  print_message("%u cuts, 0 failures\n", cuts);
}

/* RESET stores the factory defaults after its reply: a cut meanwhile boots the settings
 * before it (here changed alarms and Return Delay Time) or the defaults, never half of each. */
static void test_a_cut_anywhere_in_a_reset_boots_the_settings_before_it_or_the_defaults(void **state) {
  (void)state;
  uint8_t setup[16];
  uint8_t packet[16];
  const size_t setup_len = packet_encode(setup, 1, DXL_INST_WRITE, HP(CT_ADDR_RETURN_DELAY_TIME, 20, 0x00, 0x01));
  const size_t packet_len = packet_encode(packet, 1, DXL_INST_RESET, H_NO_PARAMS);
  const unsigned cuts = cut_everywhere(setup, setup_len, packet, packet_len, 1, 1);
  print_message("%u cuts, 0 failures\n", cuts);
}

/* docs/policy.md "Settings": a second EEPROM WRITE while the first is being stored is stored
 * by the next store, never lost: both values survive a restart once stored, and each is
 * answered at once. */
static void test_a_second_eeprom_write_during_a_store_is_stored_too(void **state) {
  (void)state;
  char dir[256];
  harness_tempdir(dir, sizeof dir);
  harness_t h;
  servo_t *servo = boot_servo(&h, dir);
  uint8_t reply[64];
  uint8_t packet[16];
  size_t len = packet_encode(packet, 1, DXL_INST_WRITE, HP(CT_ADDR_RETURN_DELAY_TIME, 10, 0x00, 0x01));
  assert_int_equal(harness_exchange(&h, packet, len, STATUS_LEN(0), reply, sizeof reply), STATUS_LEN(0));
  const uint64_t writes_before = servo->eeprom_writes;
  len = packet_encode(packet, 1, DXL_INST_WRITE, HP(CT_ADDR_ALARM_LED, 0x25, 0x25));
  assert_int_equal(harness_exchange(&h, packet, len, STATUS_LEN(0), reply, sizeof reply), STATUS_LEN(0));
  assert_true(servo->eeprom_writes - writes_before < 3u); /* the first store still under way */
  world_run_until(h.world, h.world->now + sim_ms(200));
  /* A cut now (no settling): the EEPROM as it is holds both writes. */
  static uint8_t eeprom[EEPROM_BYTES];
  memcpy(eeprom, servo->eeprom, EEPROM_BYTES);
  harness_close(&h);
  const uint8_t *settings = dxl_image_settings(eeprom);
  assert_non_null(settings);
  assert_int_equal(settings[CT_ADDR_RETURN_DELAY_TIME], 10);
  assert_int_equal(settings[CT_ADDR_CW_ANGLE_LIMIT + 1], 0x01);
  assert_int_equal(settings[CT_ADDR_ALARM_LED], 0x25);
  assert_int_equal(settings[CT_ADDR_ALARM_SHUTDOWN], 0x25);
  harness_rmdir(dir);
}

/* ---- a stream of writes ---- */

#define STREAM_MS 2000u
#define STREAM_BOUND_MS 100u
#define STREAM_MAX_WRITES 32768u
#define STREAM_MAX_CAPTURES 1024u
#define BYTE_WRITE_MS 3.4
#define FACTORY_MAX_TORQUE 1023u
/* Every STREAM_TORN_BOOT_EVERY-th torn capture is also booted in simavr (every one is decoded
 * by the core's dxl_image_settings, the function nvm_load uses). */
#define STREAM_TORN_BOOT_EVERY 8u

typedef struct {
  sim_cycles_t answered[STREAM_MAX_WRITES]; /* end of write i's reply */
  size_t writes;
  sim_cycles_t cw_answered; /* the WRITE of CW Angle Limit 200 before the stream */
  uint8_t eeprom[STREAM_MAX_CAPTURES][EEPROM_BYTES]; /* after each byte the firmware wrote */
  size_t written_addr[STREAM_MAX_CAPTURES];
  sim_cycles_t written_at[STREAM_MAX_CAPTURES]; /* at or just after that byte's write began */
  size_t captures;
  sim_cycles_t end;
} stream_t;

/* Max Torque written by write i of the stream: never the factory value, the same again only
 * after 1000 writes (about 200 ms at this pace). */
static uint16_t stream_value(size_t i) { return (uint16_t)(i % 1000u); }

/* Writes the stream gave answers to by time t. */
static size_t answered_by(const stream_t *s, sim_cycles_t t) {
  size_t n = 0;
  while (n < s->writes && s->answered[n] <= t) {
    n++;
  }
  return n;
}

/* Which write settings hold: the newest one answered by t with their Max Torque, -1 for the
 * settings before the stream, -2 for the settings before the WRITE of CW 200. Fails on a mix:
 * every other byte must be the one the servo was given. */
static long stream_write_of(const stream_t *s, const uint8_t *settings, sim_cycles_t t, const uint8_t base[CT_EEPROM_SIZE],
                            const char *what) {
  if (settings == NULL) {
    fail_msg("%s: no valid settings (factory defaults would boot)", what);
  }
  uint8_t expect[CT_EEPROM_SIZE];
  memcpy(expect, base, CT_EEPROM_SIZE);
  const uint16_t torque = ct_get_u16(settings, CT_ADDR_MAX_TORQUE);
  ct_set_u16(expect, CT_ADDR_MAX_TORQUE, torque);
  long which = -1;
  if (torque == FACTORY_MAX_TORQUE) {
    if (ct_get_u16(settings, CT_ADDR_CW_ANGLE_LIMIT) == 100u) {
      ct_set_u16(expect, CT_ADDR_CW_ANGLE_LIMIT, 100u);
      which = -2;
    }
  } else {
    which = (long)answered_by(s, t) - 1;
    while (which >= 0 && stream_value((size_t)which) != torque) {
      which--;
    }
    if (which < 0) {
      fail_msg("%s: Max Torque %u, which no answered write gave", what, torque);
    }
  }
  if (memcmp(settings, expect, CT_EEPROM_SIZE) != 0) {
    char got_hex[128];
    char want_hex[128];
    fail_msg("%s: boots %s, a mix: not %s", what, packet_hex(settings, CT_EEPROM_SIZE, got_hex, sizeof got_hex),
             packet_hex(expect, CT_EEPROM_SIZE, want_hex, sizeof want_hex));
  }
  return which;
}

/* The EEPROM area a servo booted in simavr from eeprom answers with (ID 1, 1 Mbps throughout). */
static void boot_and_read(const uint8_t *eeprom, uint8_t area[CT_EEPROM_SIZE], const char *what) {
  char dir[256];
  save_state(dir, sizeof dir, eeprom);
  harness_t h;
  harness_open(&h, "ax12", MCU, 1);
  harness_add_servo(&h, 1, 1, dir);
  harness_boot(&h, 5);
  if (!read_settings(&h, 1, area)) {
    fail_msg("%s: the booted servo does not answer", what);
  }
  harness_close(&h);
  harness_rmdir(dir);
}

/* The stream: CW Angle Limit 100 stored, CW 200 answered, then WRITEs of Max Torque (two
 * bytes) back to back, each sent as soon as the reply to the last has ended, for STREAM_MS;
 * every byte the firmware writes to its EEPROM is captured. */
static void run_stream(stream_t *s, uint8_t base[CT_EEPROM_SIZE]) {
  char dir[256];
  harness_tempdir(dir, sizeof dir);
  harness_t h;
  servo_t *servo = boot_servo(&h, dir);
  uint8_t reply[64];
  /* Return Delay Time 0 (the fastest stream) and CW 100, stored */
  assert_int_equal(harness_request(&h, 1, DXL_INST_WRITE, HP(CT_ADDR_RETURN_DELAY_TIME, 0, 100, 0), STATUS_LEN(0), reply),
                   STATUS_LEN(0));
  world_run_until(h.world, h.world->now + sim_ms(300));
  master_requester_t back_to_back = h.requester;
  back_to_back.wait.quiet_after = 0; /* the next request right after the reply's last byte */
  const master_reply_t cw =
      master_request(&back_to_back, 1, DXL_INST_WRITE, HP(CT_ADDR_CW_ANGLE_LIMIT, 200, 0), STATUS_LEN(0), reply, sizeof reply);
  assert_int_equal(cw.received, STATUS_LEN(0));
  s->cw_answered = h.world->now;
  assert_true(read_settings(&h, 1, base)); /* CW 200; Max Torque as each write sets it */
  memcpy(s->eeprom[0], servo->eeprom, EEPROM_BYTES);
  s->written_at[0] = h.world->now;
  s->captures = 1;
  s->writes = 0;
  uint64_t writes = servo->eeprom_writes;
  const sim_cycles_t stream_end = h.world->now + sim_ms(STREAM_MS);
  s->end = stream_end + sim_ms(2u * STREAM_BOUND_MS);
  while (h.world->now < s->end) {
    if (h.world->now < stream_end) {
      assert_true(s->writes < STREAM_MAX_WRITES);
      const uint16_t value = stream_value(s->writes);
      const master_reply_t r = master_request(&back_to_back, 1, DXL_INST_WRITE,
                                              HP(CT_ADDR_MAX_TORQUE, (uint8_t)(value & 0xFFu), (uint8_t)(value >> 8)),
                                              STATUS_LEN(0), reply, sizeof reply);
      assert_int_equal(r.received, STATUS_LEN(0));
      assert_int_equal(reply[4], 0); /* no error */
      s->answered[s->writes++] = h.world->now;
    } else {
      world_run_until(h.world, h.world->now + sim_us(100));
    }
    assert_true(s->captures < STREAM_MAX_CAPTURES);
    const size_t addr = captured_write(servo, &writes, s->eeprom[s->captures - 1u], s->eeprom[s->captures]);
    if (addr < EEPROM_BYTES) {
      s->written_addr[s->captures] = addr;
      s->written_at[s->captures++] = h.world->now;
    }
  }
  harness_close(&h);
  harness_rmdir(dir);
}

/* docs/policy.md "Settings": a stream of EEPROM WRITEs back to back for 2 s (about 10 000 at
 * Return Delay Time 0) after a WRITE of CW Angle Limit. A cut at every byte the firmware
 * writes (between two bytes, and in the byte: left at 0x00 or 0xFF), each booted: complete
 * settings of an answered write every time, never older than the last one stored, the CW
 * write 2 s earlier kept, and every write answered at t stored by t + 100 ms (a byte is in
 * 3.4 ms after it starts; a cut sees the settings before a byte until then). */
static void test_a_stream_of_writes_is_stored_within_100_ms_and_a_cut_anywhere_keeps_every_stored_write(void **state) {
  (void)state;
  static stream_t s;
  uint8_t base[CT_EEPROM_SIZE];
  run_stream(&s, base);
  assert_true(s.writes > 2000u);
  assert_true(s.captures > 100u);
  long stored = -2;
  long longest_ms = 0;
  unsigned elf_boots = 0;
  for (size_t k = 0; k < s.captures; k++) {
    char what[160];
    /* capture k holds until the next byte's write is in (or, the last, until the end) */
    const sim_cycles_t until =
        k + 1u < s.captures ? s.written_at[k + 1u] + (sim_cycles_t)(BYTE_WRITE_MS * 1000.0 * SIM_CYCLES_PER_US) : s.end;
    snprintf(what, sizeof what, "cut after EEPROM byte %zu of %zu (%.1f ms into the stream)", k, s.captures - 1u,
             (double)(s.written_at[k] - s.cw_answered) / (double)sim_ms(1));
    const long which = stream_write_of(&s, dxl_image_settings(s.eeprom[k]), s.written_at[k], base, what);
    uint8_t booted[CT_EEPROM_SIZE];
    boot_and_read(s.eeprom[k], booted, what);
    elf_boots++;
    assert_memory_equal(booted, dxl_image_settings(s.eeprom[k]), CT_EEPROM_SIZE); /* the firmware boots it */
    if (which < stored) {
      fail_msg("%s: boots write %ld, older than write %ld stored before", what, which, stored);
    }
    stored = which;
    /* the CW write, and every write answered 100 ms before `until`, are in */
    const sim_cycles_t due_by = until - sim_ms(STREAM_BOUND_MS);
    if (until > s.cw_answered + sim_ms(STREAM_BOUND_MS) && which < -1) {
      fail_msg("%s: the CW write answered %.1f ms before is lost", what,
               (double)(until - s.cw_answered) / (double)sim_ms(1));
    }
    const size_t answered = answered_by(&s, due_by);
    const long due = answered > 0 ? (long)answered - 1 : -2;
    if (which < due) {
      fail_msg("%s: write %ld is stored, but write %ld was answered at least %u ms before", what, which, due,
               STREAM_BOUND_MS);
    }
    if (which >= 0 && s.written_at[k] < s.answered[s.writes - 1u]) {
      const size_t newest = answered_by(&s, s.written_at[k]) - 1u;
      const long lag_ms = (long)((s.answered[newest] - s.answered[which]) / sim_ms(1));
      longest_ms = lag_ms > longest_ms ? lag_ms : longest_ms;
    }
    if (k == 0) {
      continue;
    }
    for (size_t t = 0; t < sizeof torn_values; t++) {
      uint8_t torn[EEPROM_BYTES];
      tear(s.eeprom[k], s.written_addr[k], t, k, s.captures - 1u, torn, what, sizeof what);
      const long torn_which = stream_write_of(&s, dxl_image_settings(torn), s.written_at[k], base, what);
      if (torn_which != which && torn_which != stream_write_of(&s, dxl_image_settings(s.eeprom[k - 1u]),
                                                                s.written_at[k], base, what)) {
        fail_msg("%s: boots write %ld, neither the settings before the byte nor after it", what, torn_which);
      }
      if ((k * sizeof torn_values + t) % STREAM_TORN_BOOT_EVERY == 0) {
        uint8_t booted_torn[CT_EEPROM_SIZE];
        boot_and_read(torn, booted_torn, what);
        elf_boots++;
        assert_memory_equal(booted_torn, dxl_image_settings(torn), CT_EEPROM_SIZE);
      }
    }
  }
  assert_int_equal(stored, (long)s.writes - 1); /* the last write too, once the stream stops */
  print_message("%zu writes answered in %u ms, %zu EEPROM bytes written, %zu cuts (%u booted in simavr); the stored "
                "write at most %ld ms behind the newest answered\n",
                s.writes, STREAM_MS, s.captures - 1u, s.captures + 2u * (s.captures - 1u), elf_boots, longest_ms);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_a_cut_anywhere_in_a_write_of_id_baud_and_delay_boots_old_or_new),
      cmocka_unit_test(test_a_cut_anywhere_in_an_eight_byte_write_boots_old_or_new),
      cmocka_unit_test(test_a_cut_anywhere_in_a_reset_boots_the_settings_before_it_or_the_defaults),
      cmocka_unit_test(test_a_second_eeprom_write_during_a_store_is_stored_too),
      cmocka_unit_test(test_a_stream_of_writes_is_stored_within_100_ms_and_a_cut_anywhere_keeps_every_stored_write),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
