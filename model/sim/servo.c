/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "servo.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <avr_eeprom.h>
#include <avr_timer.h>
#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_core.h>
#include <sim_elf.h>
#include <sim_io.h>

#include "sim_log.h"

static void sleep_nothing(avr_t *avr, avr_cycle_count_t how_long) {
  (void)avr;
  (void)how_long; /* the world paces itself (world.c); simavr only jumps the clock */
}

static void set_power_on_flag(avr_t *avr);
static void run_step(avr_t *avr);

static avr_eeprom_t *find_eeprom(avr_t *avr) {
  for (avr_io_t *io = avr->io_port; io; io = io->next) {
    if (io->kind && strcmp(io->kind, "eeprom") == 0) {
      return (avr_eeprom_t *)io;
    }
  }
  return NULL;
}

/* simavr stores an EEPROM byte the moment EEPE is written (EEMPE set) and clears EEPE at
 * once; only the EE_READY interrupt comes 3.4 ms later. Silicon keeps EEPE set for the whole
 * write, and firmware polls it (eeprom_is_ready()). The servo restores that: EEPE reads 1
 * from the write until 3.4 ms later (one cycle before simavr raises EE_READY, so a woken
 * main loop sees the EEPROM ready). */
static avr_cycle_count_t eeprom_write_done(avr_t *avr, avr_cycle_count_t when, void *param) {
  (void)when;
  servo_t *servo = param;
  avr_regbit_clear(avr, find_eeprom(avr)->eepe);
  servo->eeprom_busy = false;
  return 0;
}

/* avr_reset() dropped the completion timer (simavr stored the byte already). */
static void servo_was_reset(void *ctx) {
  servo_t *servo = ctx;
  servo->eeprom_busy = false;
}

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

static int prepare_eeprom(servo_t *servo, const servo_config_t *config, uint8_t *image, char *err, size_t err_len) {
  if (config->eeprom) {
    memset(image, 0xFF, servo->eeprom_size);
    memcpy(image, config->eeprom, config->eeprom_len < servo->eeprom_size ? config->eeprom_len : servo->eeprom_size);
    memcpy(servo->persisted, image, servo->eeprom_size);
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
    memcpy(servo->persisted, image, servo->eeprom_size);
    return 0;
  }
  eeprom_store_seed(image, servo->eeprom_size, config->profile, config->id, config->baud_reg);
  if (config->state_path) {
    if (eeprom_store_save(config->state_path, image, servo->eeprom_size, err, err_len) != 0) {
      return -1;
    }
  }
  memcpy(servo->persisted, image, servo->eeprom_size);
  return 0;
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
  avr->sleep = sleep_nothing;
  avr->run = run_step;
  set_power_on_flag(avr);

  avr_eeprom_t *ee = find_eeprom(avr);
  if (!ee || !ee->eeprom) {
    snprintf(err, err_len, "MCU '%s' has no EEPROM in simavr", config->mcu);
    servo_destroy(servo);
    return NULL;
  }
  servo->eeprom = ee->eeprom;
  servo->eeprom_size = ee->size;
  servo->persisted = malloc(servo->eeprom_size);
  uint8_t *image = malloc(servo->eeprom_size);
  if (!servo->persisted || !image) {
    free(image);
    snprintf(err, err_len, "out of memory");
    servo_destroy(servo);
    return NULL;
  }
  if (prepare_eeprom(servo, config, image, err, err_len) != 0) {
    free(image);
    servo_destroy(servo);
    return NULL;
  }
  memcpy(servo->eeprom, image, servo->eeprom_size);
  free(image);

  io_hook_write(avr, ee->r_eecr, eecr_write, servo, &servo->eecr_replaced);

  if (!board_attach(&servo->board, avr, bus, servo->name)) {
    snprintf(err, err_len, "MCU '%s' lacks a part the board needs (USART0, ports B/D) or the bus is full",
             config->mcu);
    servo_destroy(servo);
    return NULL;
  }
  for (avr_io_t *io = avr->io_port; io && servo->timer_count < sizeof(servo->timers) / sizeof(servo->timers[0]);
       io = io->next) {
    if (io->kind && strcmp(io->kind, "timer") == 0) {
      servo->timers[servo->timer_count++] = io;
      if (((avr_timer_t *)io)->name == '0' && !quiet_timer_attach(&servo->quiet_timer0, avr, (avr_timer_t *)io)) {
        snprintf(err, err_len, "MCU '%s': Timer0 is not where the emulator expects it", config->mcu);
        servo_destroy(servo);
        return NULL;
      }
    }
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
  }
  if (servo->avr) {
    avr_terminate(servo->avr);
    board_detach(&servo->board);
    free(servo->avr);
  }
  free(servo->persisted);
  free(servo);
}

/* One step of the core, as simavr 1.6's avr_callback_run_raw() without its sleep: run
 * instructions (if awake), the due cycle timers, and the interrupts. A sleeping core's clock
 * is advanced by servo_run_until() instead, exactly to its next timer (simavr would jump one
 * cycle past it, and from there to the following timer within the same call).
 *
 * A running core executes a batch: avr_run_one() goes on from instruction to instruction
 * while avr->run_cycle_count cycles are left, the core runs and no interrupt is pending.
 * step_core() sets the count to reach the first cycle timer or `until`, whichever comes
 * first. An instruction that registers or cancels a cycle timer (a UDR0 read, an ADC start,
 * WDR...) makes simavr re-clamp the count to min(run_cycle_limit, first timer - now); with
 * run_cycle_limit at 1 (simavr's own value after avr_init and every reset) the batch then
 * ends after that instruction, and the next step_core() bounds a new one. So a batch ends at
 * the first instruction boundary at or after the first cycle timer or `until`, which is
 * where an instruction-by-instruction loop would have stopped: the same cycles, fewer calls.
 * until = 0 runs one instruction (single_step; the busy-time probe looks at every one). */
static inline __attribute__((always_inline)) void step_core(avr_t *avr, sim_cycles_t until) {
  avr_flashaddr_t new_pc = avr->pc;
  if (avr->state == cpu_Running) {
    const avr_cycle_timer_slot_p first = avr->cycle_timers.timer;
    const sim_cycles_t end = first && first->when < until ? first->when : until;
    avr->run_cycle_count = end > avr->cycle ? end - avr->cycle : 1u;
    new_pc = avr_run_one(avr);
  }
  const avr_cycle_timer_slot_p due = avr->cycle_timers.timer;
  if (due && due->when <= avr->cycle) { /* what avr_cycle_timer_process() checks first */
    (void)avr_cycle_timer_process(avr);
  }
  avr->pc = new_pc;
  if (avr->state == cpu_Sleeping && !avr->sreg[S_I]) {
    avr->state = cpu_Done; /* SLEEP with interrupts off: nothing can wake it */
    return;
  }
  if ((avr->state == cpu_Running || avr->state == cpu_Sleeping) && avr->interrupt_state) {
    avr_service_interrupts(avr);
  }
}

static void run_step(avr_t *avr) { step_core(avr, 0); }

/* One instruction (or an interrupt's entry), its cycles added to the profile (servo_t). */
static __attribute__((noinline)) void profiled_step(servo_t *servo) {
  avr_t *avr = servo->avr;
  const avr_flashaddr_t pc_before = avr->pc;
  const sim_cycles_t cycle_before = avr->cycle;
  step_core(avr, 0);
  servo->pc_cycles[(pc_before / 2u) % servo->pc_cycles_words] += avr->cycle - cycle_before;
}

/* Busy-time probe: from the instruction at probe_pc (an ISR's entry) until the core sleeps
 * again. An entry while already inside (the work overran into the next period) extends it. */
static void probe(servo_t *servo) {
  avr_t *avr = servo->avr;
  if (!servo->probe_inside) {
    if (avr->pc == servo->probe_pc) {
      servo->probe_start = avr->cycle;
      servo->probe_inside = true;
    }
    return;
  }
  if (avr->state == cpu_Sleeping) {
    const sim_cycles_t spent = avr->cycle - servo->probe_start;
    servo->probe_inside = false;
    servo->probe_calls++;
    servo->probe_total_cycles += spent;
    if (spent > servo->probe_max_cycles) {
      servo->probe_max_cycles = spent;
    }
  }
}

void servo_set_probe(servo_t *servo, uint32_t entry_pc) {
  servo->probe_pc = entry_pc;
  servo->probe_inside = false;
  servo->probe_calls = 0;
  servo->probe_max_cycles = servo->probe_total_cycles = 0;
}

void servo_show_plant(servo_t *servo) {
  if (!servo->has_plant) {
    return;
  }
  const ax12_plant_t *p = &servo->plant;
  board_set_analog_mv(&servo->board, ax12_plant_pot_mv(p), ax12_plant_supply_sense_mv(p), ax12_plant_temp_sense_mv(p));
}

void servo_attach_plant(servo_t *servo, const ax12_plant_t *plant) {
  servo->plant = *plant;
  servo->has_plant = true;
  servo->plant_at = servo->avr->cycle;
  if (servo->plant_due && servo->plant_at + SERVO_PLANT_STEP < *servo->plant_due) {
    *servo->plant_due = servo->plant_at + SERVO_PLANT_STEP;
  }
  servo_show_plant(servo);
}

void servo_step_plant(servo_t *servo, sim_cycles_t now, bool force) {
  if (!servo->has_plant || now <= servo->plant_at || (!force && now - servo->plant_at < SERVO_PLANT_STEP)) {
    return;
  }
  ax12_plant_step(&servo->plant, board_pwm_duty(&servo->board), (double)(now - servo->plant_at) / SIM_CPU_HZ);
  servo->plant_at = now;
  servo_show_plant(servo);
}

sim_cycles_t servo_earliest_wake(const servo_t *servo, sim_cycles_t now) {
  const avr_t *avr = servo->avr;
  if (servo->halted) {
    return SIM_CYCLES_NEVER;
  }
  if (avr->state != cpu_Sleeping || avr->interrupt_state) {
    return now;
  }
  /* The first timer that can wake it; a timer module's quietness is looked up only when one
   * of its events comes first (usually the first slot is the control tick's, or a byte's). */
  for (avr_cycle_timer_slot_p slot = avr->cycle_timers.timer; slot; slot = slot->next) {
    bool skip = false;
    for (unsigned i = 0; i < servo->timer_count; i++) {
      if (slot->param == servo->timers[i]) {
        skip = quiet_timer_interrupts_off((avr_t *)avr, servo->timers[i]);
        break;
      }
    }
    if (!skip) {
      return slot->when > now ? slot->when : now;
    }
  }
  return SIM_CYCLES_NEVER;
}

void servo_run_until(servo_t *servo, sim_cycles_t t) {
  avr_t *avr = servo->avr;
  if (servo->halted || avr->cycle >= t) {
    return;
  }
  const avr_cycle_timer_slot_p first = avr->cycle_timers.timer;
  if (avr->state == cpu_Sleeping && !avr->interrupt_state && (!first || first->when >= t)) {
    servo->sleep_cycles += t - avr->cycle; /* nothing wakes it before t: the usual case */
    avr->cycle = t;
    return;
  }
  avr->run_cycle_limit = 1; /* a re-clamp ends the batch (step_core) */
  const sim_cycles_t until = servo->single_step || servo->probe_pc ? 0 : t; /* profiled_step: 0 too */
  while (!servo->halted && avr->cycle < t) {
    if (avr->state == cpu_Sleeping) {
      const avr_cycle_timer_slot_p next = avr->cycle_timers.timer;
      if (!next || next->when >= t) {
        servo->sleep_cycles += t - avr->cycle;
        avr->cycle = t;
        break;
      }
      if (next->when > avr->cycle) {
        servo->sleep_cycles += next->when - avr->cycle;
        avr->cycle = next->when;
      }
    }
    if (__builtin_expect(servo->pc_cycles != NULL, 0)) {
      profiled_step(servo);
    } else {
      step_core(avr, until);
    }
    if (servo->probe_pc) {
      probe(servo);
    }
    if (avr->state == cpu_Done || avr->state == cpu_Crashed) {
      servo->halted = true;
      servo->halt_state = avr->state;
      fprintf(stderr, "%s: the MCU stopped (%s) at cycle %llu, pc 0x%04x\n", servo->name,
              avr->state == cpu_Done ? "sleep with interrupts off" : "crash", (unsigned long long)avr->cycle,
              (unsigned)avr->pc);
    }
  }
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

bool servo_listening(const servo_t *servo) {
  return !servo->halted && avr_regbit_get(servo->avr, servo->board.link.uart->rxen);
}

void servo_reset(servo_t *servo) {
  avr_reset(servo->avr);
  servo->halted = false;
}

static void set_power_on_flag(avr_t *avr) {
  if (avr->reset_flags.porf.reg) {
    avr_regbit_set(avr, avr->reset_flags.porf);
  }
}

void servo_power_cycle(servo_t *servo) {
  servo_reset(servo);
  set_power_on_flag(servo->avr);
}

unsigned servo_stack_depth(const servo_t *servo, uint16_t bss_end, uint8_t paint_pattern) {
  const avr_t *avr = servo->avr;
  const unsigned ramend = avr->ramend;
  for (unsigned addr = bss_end; addr <= ramend; addr++) {
    if (avr->data[addr] != paint_pattern) {
      return ramend - addr + 1u;
    }
  }
  return 0;
}
