/* SPDX-License-Identifier: GPL-3.0-or-later */
/* One AX-12: an ATmega88 (or ATmega328P) in simavr running the firmware ELF, on its board,
 * with its EEPROM (and a flash changed by SPM) kept in state files. This module is the MCU's
 * lifecycle (create, reset, power cycle, destroy); the servo's other jobs each have their
 * module, all on this servo_t:
 *   servo_boot.h     the bootloader and its application record in the flash, the reset vector
 *   servo_eeprom.h   EEPROM write timing and persistence to the state file
 *   servo_flash.h    SPM timing and persistence of the flash to its state file
 *   servo_run.h      running the core: batches, sleep, the earliest wake (fast_core.h runs them)
 *   servo_plant.h    the plant (model/plant) behind the board's pins
 *   servo_profile.h  the busy-time probe and the cycle profile by instruction
 *   servo_stack.h    the stack depth from the firmware's stack paint
 *   servo_gdb.h      the firmware opened to avr-gdb
 *   servo_trace.h    the probes of a waveform trace (world_trace.h) */
#ifndef SIM_SERVO_H
#define SIM_SERVO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "board.h"
#include "bus.h"
#include "eeprom_store.h"
#include "plant.h"
#include "plant_joint.h"
#include "quiet_timer.h"
#include "sim_time.h"

struct avr_t;
struct avr_flash_t;
struct fast_core;
struct elf_firmware_t;
struct servo_bootloader;
struct servo_gdb;

/* Where a servo's flash came from at servo_create (servo_flash.h). */
typedef enum {
  SERVO_FLASH_FROM_ELF = 0,          /* the ELFs; there was no flash state file */
  SERVO_FLASH_FROM_STATE,            /* the flash state file, of this build */
  SERVO_FLASH_DROPPED_OTHER_BUILD,   /* the ELFs; the state file was of another build: removed */
  SERVO_FLASH_DROPPED_INVALID,       /* the ELFs; the state file was no flash image of this MCU: removed */
} servo_flash_origin_t;

typedef struct {
  const char *name;                       /* for messages and the bus, e.g. "servo-1" */
  const struct elf_firmware_t *firmware;  /* loaded once, shared by every servo */
  const char *mcu;                        /* "atmega88" or "atmega328p" */
  const char *state_path;                 /* NULL: the EEPROM (and flash) live in memory only;
                                             the flash's file is beside it (flash_store.h) */
  const struct servo_bootloader *bootloader; /* NULL: none (reset at 0, no record) */
  eeprom_profile_t profile;               /* for seeding a fresh EEPROM */
  uint8_t id;                             /* ID of a fresh EEPROM */
  uint8_t baud_reg;                       /* Baud Rate register of a fresh EEPROM */
  const uint8_t *eeprom;                  /* if not NULL: the EEPROM at power-up (tests) */
  size_t eeprom_len;
} servo_config_t;

typedef struct servo {
  struct avr_t *avr;
  /* The decoded-instruction interpreter that runs avr's batches (fast_core.h); NULL: simavr's
   * own avr_run_one (AX12_SIM_CORE=simavr). */
  struct fast_core *fast_core;
  board_t board;
  char name[32];
  char state_path[4096];
  bool ready; /* fully created */
  bool halted;
  uint64_t watchdog_resets; /* resets by the firmware's watchdog (servo_run.c) */
  int halt_state; /* simavr cpu state when it stopped (cpu_Done, cpu_Crashed) */
  /* EEPROM watch and persistence (servo_eeprom.c). */
  uint8_t *eeprom; /* simavr's bytes */
  size_t eeprom_size;
  uint8_t *persisted; /* what the state file holds */
  bool dirty;        /* written since the last persist */
  bool eeprom_busy;  /* a byte write is under way (EEPE held) */
  sim_cycles_t last_write_at;
  io_write_hook_t eecr_replaced; /* simavr's EECR handler, chained to */
  uint64_t eeprom_writes;
  uint64_t eeprom_writes_while_busy;
  uint64_t persists;
  uint64_t persist_errors;
  char last_error[256];
  /* Flash under self-programming and its persistence (servo_flash.c). */
  char flash_path[4096];       /* "" when the flash lives in memory only */
  uint32_t flash_bytes;
  uint64_t flash_identity;     /* of the flash as the ELFs loaded it (flash_store_identity) */
  servo_flash_origin_t flash_origin;
  struct avr_flash_t *flash_module; /* simavr's SPM module */
  void *spm_io;                /* avr_io_t that sees every SPM before simavr's module */
  io_write_hook_t spmcsr_replaced; /* simavr's SPMCSR handler, chained to */
  uint32_t boot_section;       /* first byte of the boot section: SPM runs from there only */
  uint32_t nrww_start;         /* first byte of the NRWW section (no RWWSB for its pages) */
  bool flash_dirty;            /* changed by SPM since the last persist */
  bool spm_busy;               /* a page erase or write under way: SPMEN held */
  bool rww_busy;               /* RWWSB: set until the RWWSRE SPM */
  uint64_t spm_page_ops;       /* page erases and writes done */
  uint64_t spm_ignored;        /* SPMs ignored: while busy, or outside the boot section */
  uint64_t flash_persists;
  /* Physics (model/plant, servo_plant.c): when has_plant, the world steps the plant with the
   * H-bridge duty and feeds its pot / supply / temperature voltages to the board. */
  bool has_plant;
  ax12_plant_t plant;
  sim_cycles_t plant_at; /* simulated time the plant has reached */
  /* The output is a robot's joint (world_robot.h): the plant steps its electrics only and sums
   * the drive the robot's physics takes at its next step. */
  bool plant_on_joint;
  ax12_joint_drive_t joint_drive;
  /* Running the core (servo_run.c). Simulated cycles the MCU has spent asleep (SLEEP until an
   * interrupt wakes it): the sum of the jumps servo_run_until() makes a sleeping core's clock
   * take. Never reset (an MCU reset keeps it); awake share over an interval
   * = 1 - (difference of sleep_cycles) / elapsed. */
  uint64_t sleep_cycles;
  /* The MCU's timer modules (simavr avr_timer_t), for servo_earliest_wake(). */
  void *timers[4];
  timer_enables_t timer_enables[4]; /* their interrupt enable bits */
  unsigned timer_count;
  /* Timer0 (the H-bridge PWM): its events are not simulated while no interrupt of it is
   * enabled (quiet_timer.h). */
  quiet_timer_t quiet_timer0;
  /* Owned by the world (NULL for a servo on its own): set when an EEPROM byte is written, so
   * the world polls persistence only then; lowered to the plant's next due time. */
  bool *persist_due;
  sim_cycles_t *plant_due;
  /* Run instruction by instruction instead of in batches up to the next cycle timer
   * (servo_run_until): slower, the same cycles; the reference a test checks batches against. */
  bool single_step;
  /* Busy-time probe (servo_profile.c: servo_set_probe). */
  uint32_t probe_pc;      /* byte address of an ISR's entry; 0 = off */
  bool probe_inside;
  sim_cycles_t probe_start;
  uint64_t probe_calls;
  sim_cycles_t probe_max_cycles, probe_total_cycles;
  /* Cycle profile (servo_profile.c): when set, the core runs one instruction a step and the
   * cycles of each step (an instruction; an interrupt's entry, counted at the instruction
   * before it) are added at its word address, modulo pc_cycles_words: with sleep_cycles they
   * add up to the elapsed cycles. Servos of one firmware may share the array on one thread. */
  uint64_t *pc_cycles;
  size_t pc_cycles_words;
  /* Opened to avr-gdb (servo_gdb.h); NULL otherwise. */
  struct servo_gdb *gdb;
} servo_t;

/* Loads the firmware into a new MCU, its EEPROM from the state file (seeded when missing:
 * see eeprom_store_seed), and wires the board onto bus. NULL with err set on failure. */
servo_t *servo_create(const servo_config_t *config, bus_t *bus, char *err, size_t err_len);

/* Frees everything; persists a changed EEPROM first (call when no write is in progress). */
void servo_destroy(servo_t *servo);

/* True once the firmware has enabled the USART receiver (it can hear the bus). */
bool servo_listening(const servo_t *servo);

/* True once a client can talk to the servo (since_power_up: simulated time): it listens,
 * and if a bootloader runs first, the application does with its receive interrupt on, or
 * BOOT_WINDOW_DONE_MS have passed (the bootloader stayed: no valid application, past its '#'
 * window at 57 600 baud, docs/bootloader.md "At reset"; or an application that polls). */
bool servo_ready_for_clients(const servo_t *servo, sim_cycles_t since_power_up);

/* Pulls the MCU's reset line (as the watchdog would): RAM, I/O and the USART restart,
 * the EEPROM stays. */
void servo_reset(servo_t *servo);

/* Power off and on: as servo_reset, with the power-on reset flag (PORF) set in MCUSR. */
void servo_power_cycle(servo_t *servo);

#endif
