/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Helpers for the simulator tests: a world of servos running the firmware ELF and a master
 * on the bus, and exchanges bounded by simulated time (model/bus/master_request.h; packets
 * from model/bus/packet_encode.h, the manual's encoding, not the firmware's). */
#ifndef SIM_HARNESS_H
#define SIM_HARNESS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "master.h"
#include "master_request.h"
#include "packet_encode.h"
#include "servo.h"
#include "servo_eeprom.h"
#include "servo_plant.h"
#include "servo_profile.h"
#include "servo_run.h"
#include "servo_stack.h"
#include "world.h"

#define HARNESS_MAX_REPLY 1024u
/* Longest a reply may take to start before the exchange gives up: far above any reply's
 * (Return Delay Time 254 is 508 us; no reply waits for the EEPROM), so a late reply shows as
 * late in the test's timing checks rather than as missing. */
#define HARNESS_REPLY_TIMEOUT_MS 150u
/* Silence that ends an exchange once bytes came back. */
#define HARNESS_QUIET_US 2000u
/* How long "nothing comes back" is watched: below the 100 ms gap that discards a partial
 * packet, so scenarios that split a packet across exchanges still work. */
#define HARNESS_SILENCE_MS 90u

typedef struct {
  world_t *world;
  master_t *master;
  master_requester_t requester; /* the master on the world, waits of HARNESS_* */
  char elf[1024];
} harness_t;

/* Path of ax12-<profile>-<mcu>.elf in AX12_FIRMWARE_DIR. */
const char *harness_elf_path(const char *profile, const char *mcu);

/* A world on that ELF with a master at Baud Rate register master_baud; no servos yet.
 * Skips the test (cmocka skip) when the ELF is missing and the firmware is not part of the
 * build, fails it when it should be there. */
void harness_open(harness_t *h, const char *profile, const char *mcu, unsigned master_baud);
/* The same with the ELF at elf (of that profile and MCU). */
void harness_open_elf(harness_t *h, const char *elf, const char *profile, const char *mcu, unsigned master_baud);
/* Stops cleanly: runs the servos until their EEPROM is quiet (at most HARNESS_SETTLE_MS of
 * simulated time, as the emulator does on SIGTERM) and writes their state files. */
#define HARNESS_SETTLE_MS 500u
void harness_close(harness_t *h);

/* Adds a servo for slot id (state file in state_dir when not NULL) and returns it. */
servo_t *harness_add_servo(harness_t *h, uint8_t id, uint8_t baud_reg, const char *state_dir);

/* Runs until every servo listens (servo_ready_for_clients: its application, when a bootloader
 * runs first), plus settle_ms (power-up work). Call right after power-up. Fails after 1 s. */
void harness_boot(harness_t *h, unsigned settle_ms);

/* Every servo's MCU restarts (EEPROM kept, RAM not), then boots; the EEPROM writes under way
 * finish first (at most HARNESS_SETTLE_MS). */
void harness_power_cycle(harness_t *h);

/* Sends bytes and collects what comes back: until expect bytes came and the line was quiet
 * for HARNESS_QUIET_US (expect 0: for HARNESS_SILENCE_MS). Returns how many came back;
 * their wire records stay in h->master. */
size_t harness_exchange(harness_t *h, const uint8_t *bytes, size_t count, size_t expect, uint8_t *reply,
                        size_t reply_max);

/* Sends a packet and expects a status packet of reply_len bytes (0: none). Returns the
 * number of bytes that came back. */
size_t harness_request(harness_t *h, uint8_t id, uint8_t instruction, const uint8_t *params, size_t count,
                       size_t reply_len, uint8_t *reply);

/* A fresh empty directory under /tmp for state files; harness_rmdir removes it. */
void harness_tempdir(char *out, size_t len);
void harness_rmdir(const char *dir);

#define HP(...) (const uint8_t[]){__VA_ARGS__}, sizeof((const uint8_t[]){__VA_ARGS__})
#define H_NO_PARAMS NULL, 0u

#endif
