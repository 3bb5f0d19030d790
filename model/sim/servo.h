/* SPDX-License-Identifier: GPL-3.0-or-later */
/* One AX-12: an ATmega88 (or ATmega328P) in simavr running the firmware ELF, on its board,
 * with its EEPROM kept in a state file.
 *
 * EEPROM timing: simavr stores a byte the moment the firmware sets EEPE (with EEMPE) and
 * raises EE_READY 3.4 ms later, but clears EEPE at once; the servo keeps EEPE set for those
 * 3.4 ms as silicon does (firmware that polls eeprom_is_ready() waits like on a board).
 *
 * Persistence: the servo watches EECR. At the end of the world step in which a byte was
 * written (< 10 us of simulated time later) the whole EEPROM is written to the state file,
 * atomically. Any consequence of the write (the reply to a WRITE) needs at least one byte
 * time (10 us at 1 Mbps, more than a step) before it leaves the simulation, so a reply proves
 * persistence, even against SIGKILL. A sequence of byte writes is persisted byte by byte,
 * exactly as the EEPROM holds it, so a kill in the middle of a sequence leaves what a power
 * cut at that moment would leave. */
#ifndef SIM_SERVO_H
#define SIM_SERVO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "board.h"
#include "bus.h"
#include "eeprom_store.h"
#include "plant.h"
#include "quiet_timer.h"
#include "sim_time.h"

struct avr_t;
struct elf_firmware_t;

#define SIM_EEPROM_WRITE_CYCLES ((sim_cycles_t)3400u * SIM_CYCLES_PER_US)
/* Quiet time after the last write completed that ends a write sequence (clean shutdown). */
#define SERVO_EEPROM_QUIET ((sim_cycles_t)1000u * SIM_CYCLES_PER_US)

typedef struct {
  const char *name;                       /* for messages and the bus, e.g. "servo-1" */
  const struct elf_firmware_t *firmware;  /* loaded once, shared by every servo */
  const char *mcu;                        /* "atmega88" or "atmega328p" */
  const char *state_path;                 /* NULL: the EEPROM lives in memory only */
  eeprom_profile_t profile;               /* for seeding a fresh EEPROM */
  uint8_t id;                             /* ID of a fresh EEPROM */
  uint8_t baud_reg;                       /* Baud Rate register of a fresh EEPROM */
  const uint8_t *eeprom;                  /* if not NULL: the EEPROM at power-up (tests) */
  size_t eeprom_len;
} servo_config_t;

typedef struct servo {
  struct avr_t *avr;
  board_t board;
  char name[32];
  char state_path[4096];
  bool ready; /* fully created */
  bool halted;
  int halt_state; /* simavr cpu state when it stopped (cpu_Done, cpu_Crashed) */
  /* EEPROM watch. */
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
  /* Physics (model/plant): when has_plant, the world steps the plant with the H-bridge duty
   * and feeds its pot / supply / temperature voltages to the board (servo_step_plant). */
  bool has_plant;
  ax12_plant_t plant;
  sim_cycles_t plant_at; /* simulated time the plant has reached */
  /* Simulated cycles the MCU has spent asleep (SLEEP until an interrupt wakes it): the sum of
   * the jumps servo_run_until() makes a sleeping core's clock take. Never reset (an MCU reset
   * keeps it); awake share over an interval = 1 - (difference of sleep_cycles) / elapsed. */
  uint64_t sleep_cycles;
  /* The MCU's timer modules (simavr avr_timer_t), for servo_earliest_wake(). */
  void *timers[4];
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
  /* Busy-time probe (servo_set_probe). */
  uint32_t probe_pc;      /* byte address of an ISR's entry; 0 = off */
  bool probe_inside;
  sim_cycles_t probe_start;
  uint64_t probe_calls;
  sim_cycles_t probe_max_cycles, probe_total_cycles;
  /* Cycle profile: when set, the core runs one instruction a step and the cycles of each step
   * (an instruction; an interrupt's entry, counted at the instruction before it) are added
   * at its word address, modulo pc_cycles_words: with sleep_cycles they add up to the
   * elapsed cycles. Servos of one firmware may share the array on one thread. */
  uint64_t *pc_cycles;
  size_t pc_cycles_words;
} servo_t;

/* Loads the firmware into a new MCU, its EEPROM from the state file (seeded when missing:
 * see eeprom_store_seed), and wires the board onto bus. NULL with err set on failure. */
servo_t *servo_create(const servo_config_t *config, bus_t *bus, char *err, size_t err_len);

/* Frees everything; persists a changed EEPROM first (call when no write is in progress). */
void servo_destroy(servo_t *servo);

/* Runs the MCU until its clock reaches t: a running core stops at the first instruction
 * boundary at or after t, a sleeping one exactly at t. A sleeping core's clock jumps from
 * one cycle timer to the next (idle firmware costs almost nothing); a running one executes
 * the instructions up to the next cycle timer (or t) in one call into simavr, which stops
 * at the same boundaries as one instruction at a time would (single_step). */
void servo_run_until(servo_t *servo, sim_cycles_t t);

/* The earliest simulated time at which this MCU may execute an instruction (and so start a
 * byte on the wire), as far as can be told at `now` without running it: `now` for a running
 * core or one with an interrupt pending; for a sleeping core the time of its first cycle
 * timer that can raise an interrupt (timer events of a timer module whose interrupts are all
 * disabled do not wake it: Timer0's PWM overflows); SIM_CYCLES_NEVER for a halted one. */
sim_cycles_t servo_earliest_wake(const servo_t *servo, sim_cycles_t now);

/* Persists the EEPROM if a byte was written since the last time. Returns -1 when a write
 * failed (message in last_error), 1 when written, 0 otherwise. */
int servo_poll_persist(servo_t *servo);

/* True while a write sequence may be under way: a write not persisted or not finished, or
 * finished less than SERVO_EEPROM_QUIET ago. */
bool servo_eeprom_unsettled(const servo_t *servo, sim_cycles_t now);

/* Persists now if the EEPROM differs from the file. */
int servo_persist(servo_t *servo);

/* True once the firmware has enabled the USART receiver (it can hear the bus). */
bool servo_listening(const servo_t *servo);

/* Pulls the MCU's reset line (as the watchdog would): RAM, I/O and the USART restart,
 * the EEPROM stays. */
void servo_reset(servo_t *servo);

/* Power off and on: as servo_reset, with the power-on reset flag (PORF) set in MCUSR. */
void servo_power_cycle(servo_t *servo);

/* Plant step: at most this much simulated time between two plant steps. */
#define SERVO_PLANT_STEP ((sim_cycles_t)100u * SIM_CYCLES_PER_US)

/* Gives the servo a plant (copied), whose readings the board shows from now on. The plant's
 * clock starts at the servo's. */
void servo_attach_plant(servo_t *servo, const ax12_plant_t *plant);
/* Steps the plant to now if it lags by SERVO_PLANT_STEP or more (force: whatever the lag),
 * with the H-bridge duty of the board, and feeds its readings to the board. */
void servo_step_plant(servo_t *servo, sim_cycles_t now, bool force);
/* Shows the plant's readings on the board (after changing the plant's state directly). */
void servo_show_plant(servo_t *servo);

/* Measures the busy time after each execution of the instruction at byte address entry_pc
 * (0 = off), typically an ISR's entry: cycles from there until the core next sleeps (the work
 * the interrupt wakes the main loop for, other interrupts meanwhile included). Count, worst
 * and total in probe_calls, probe_max_cycles, probe_total_cycles. */
void servo_set_probe(servo_t *servo, uint32_t entry_pc);

/* Stack depth: RAMEND - (lowest address above the end of .bss whose byte is not
 * paint_pattern) + 1, i.e. the deepest the stack has reached since the paint. bss_end is the
 * first free RAM address (the ELF's __bss_end / _end). */
unsigned servo_stack_depth(const servo_t *servo, uint16_t bss_end, uint8_t paint_pattern);

#endif
