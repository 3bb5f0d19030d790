/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The fast core (model/simavr/fast_core.h) against simavr's own interpreter, in lockstep: two
 * ATmega328Ps with the same random flash, registers and RAM; one steps with avr_run_one(), the
 * other with fast_core_run(), both through the emulator's run loop (simavr_patch_run.h: batches
 * up to a bound, the cycle timers, the interrupts). After every step the whole visible state must
 * be equal: PC, cycle counter, run state, interrupt state, SREG, every data byte (registers,
 * I/O, RAM), the batch's remaining cycles, the flash, and the interrupt table (pending queue,
 * running stack, the IRQ values simavr keeps for tracing). Random words reach every opcode the
 * decoder knows, and the invalid ones; writes to random I/O registers start timers, the USART,
 * the EEPROM and the watchdog, whose interrupts then run random code too. Flash words change
 * under the decoded cache during the run (as SPM and gdb change them).
 *
 * An access past the chip's memory is a crash in both cores, after which simavr still reads or
 * writes the byte there: both MCUs get data and flash buffers of the whole address range, so
 * such a byte reads alike. Before each step the test moves the pointers and SP into SRAM and Z
 * into the flash (both MCUs alike), so that most programs run a while before they crash. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_interrupts.h>

#include "fast_core.h"
#include "simavr_patch.h"
#include "simavr_patch_run.h"

#define PROGRAMS 2000u
#define STEPS_PER_PROGRAM 2000u

static uint32_t rng_state = 0x2545f491u;

static uint32_t rnd(void) {
  uint32_t x = rng_state;
  x ^= x << 13;
  x ^= x >> 17;
  x ^= x << 5;
  rng_state = x;
  return x;
}

static avr_t *make_mcu(void) {
  avr_t *avr = avr_make_mcu_by_name("atmega328p");
  assert_non_null(avr);
  avr_init(avr);
  avr->log = LOG_NONE;
  avr->frequency = 16000000u;
  simavr_install_run_loop(avr);
  const size_t data_bytes = 0x10000u + 64u, flash_bytes = (1u << 24) + 64u; /* every address an access can form */
  avr->data = realloc(avr->data, data_bytes);
  avr->flash = realloc(avr->flash, flash_bytes);
  assert_non_null(avr->data);
  assert_non_null(avr->flash);
  memset(avr->data + avr->ramend + 1, 0, data_bytes - avr->ramend - 1u);
  memset(avr->flash + avr->flashend + 1, 0, flash_bytes - avr->flashend - 1u);
  uint32_t flags = 0; /* no byte printed on stdout, no polling slow-down */
  avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
  simavr_extint_poll_off(avr);
  return avr;
}

/* Pointer values the test allows before an access: inside SRAM with room for LDD's q. */
static uint16_t sram_pointer(const avr_t *avr, uint16_t p) {
  const uint16_t low = 0x100, span = (uint16_t)(avr->ramend - 64 - low);
  return (uint16_t)(low + p % span);
}

static uint16_t word_at(const avr_t *avr, uint32_t pc) {
  return (uint16_t)(avr->flash[pc] | (avr->flash[pc + 1] << 8));
}

static void set_pair(avr_t *a, avr_t *b, uint8_t reg, uint16_t v) {
  a->data[reg] = b->data[reg] = (uint8_t)v;
  a->data[reg + 1] = b->data[reg + 1] = (uint8_t)(v >> 8);
}

/* Keeps the next instruction's accesses inside simavr's buffers, in both MCUs alike. */
static void keep_in_bounds(avr_t *a, avr_t *b) {
  const uint16_t sp = (uint16_t)(a->data[R_SPL] | (a->data[R_SPH] << 8));
  if (sp < 0x200 || sp > a->ramend) {
    set_pair(a, b, R_SPL, (uint16_t)(0x200 + sp % (a->ramend - 0x200)));
  }
  if (a->pc + 2 > a->flashend) {
    return;
  }
  const uint16_t w = word_at(a, a->pc);
  for (uint8_t reg = R_XL; reg <= R_ZL; reg += 2) {
    const uint16_t p = (uint16_t)(a->data[reg] | (a->data[reg + 1] << 8));
    set_pair(a, b, reg, sram_pointer(a, p));
  }
  const bool lpm = w == 0x95c8 || w == 0x95d8 || (w & 0xfe0c) == 0x9004;
  if (lpm) {
    a->data[0] = b->data[0] = 0; /* ELPM's RAMPZ on a part without one: r0 */
    set_pair(a, b, R_ZL, (uint16_t)((a->data[R_ZL] | (a->data[R_ZH] << 8)) & 0x7fff));
  }
  const uint16_t two = w & 0xfe0f;
  if ((two == 0x9000 || two == 0x9200) && a->pc + 4 <= a->flashend) {
    const uint16_t addr = (uint16_t)(word_at(a, a->pc + 2) % (a->ramend + 1u));
    a->flash[a->pc + 2] = b->flash[a->pc + 2] = (uint8_t)addr;
    a->flash[a->pc + 3] = b->flash[a->pc + 3] = (uint8_t)(addr >> 8);
  }
}

/* The emulator's run loop (servo_run_until) for a core that stays awake: steps to `until`
 * (0: one step, one instruction). */
static void run_to(avr_t *avr, fast_core_t *core, sim_cycles_t until) {
  simavr_end_batches_at_timer_changes(avr);
  do {
    simavr_step_core(avr, core, until);
  } while (until && avr->cycle < until && avr->state == cpu_Running && !simavr_reset_requested(avr));
}

static void fill_random(avr_t *a, avr_t *b, bool flash) {
  for (uint32_t i = 0; flash && i <= a->flashend; i++) {
    a->flash[i] = b->flash[i] = (uint8_t)rnd();
  }
  /* JMP and CALL into the flash (most random targets lie past it: a crash). */
  for (uint32_t pc = 0; flash && pc + 4 <= a->flashend; pc += 2) {
    if ((word_at(a, pc) & 0xfe0e) == 0x940c) {
      a->flash[pc] = b->flash[pc] = a->flash[pc] & 0x0e;
      a->flash[pc + 1] = b->flash[pc + 1] = 0x94;
      a->flash[pc + 3] = b->flash[pc + 3] = a->flash[pc + 3] & 0x3f;
    }
  }
  for (unsigned i = 0; i < 32; i++) {
    a->data[i] = b->data[i] = (uint8_t)rnd();
  }
  for (uint32_t i = 0x100; i <= a->ramend; i++) {
    a->data[i] = b->data[i] = (uint8_t)rnd();
  }
  for (unsigned i = 0; i < 8; i++) {
    a->sreg[i] = b->sreg[i] = (uint8_t)(rnd() & 1);
  }
  a->sreg[S_I] = b->sreg[S_I] = 0;
  a->pc = b->pc = (rnd() % ((a->flashend + 1) / 2)) * 2;
}

static bool same_irq(const avr_irq_t *a, const avr_irq_t *b) { return a->value == b->value && a->flags == b->flags; }

/* The interrupt table: the queue of pending vectors, the stack of running ones, each vector's
 * flags and the values of the IRQs simavr raises for them (which a trace would see). */
static bool same_interrupts(const avr_t *a, const avr_t *b) {
  const avr_int_table_t *ta = &a->interrupts, *tb = &b->interrupts;
  if (ta->pending.read != tb->pending.read || ta->pending.write != tb->pending.write ||
      ta->running_ptr != tb->running_ptr || ta->vector_count != tb->vector_count) {
    return false;
  }
  for (unsigned i = 0; i < avr_int_pending_fifo_size; i++) {
    const avr_int_vector_t *va = ta->pending.buffer[i], *vb = tb->pending.buffer[i];
    if ((va ? va->vector : 0) != (vb ? vb->vector : 0)) {
      return false;
    }
  }
  for (unsigned i = 0; i < ta->running_ptr; i++) {
    if (ta->running[i]->vector != tb->running[i]->vector) {
      return false;
    }
  }
  for (unsigned i = 0; i < ta->vector_count; i++) {
    const avr_int_vector_t *va = ta->vector[i], *vb = tb->vector[i];
    if (va->pending != vb->pending || !same_irq(&va->irq[0], &vb->irq[0]) || !same_irq(&va->irq[1], &vb->irq[1])) {
      return false;
    }
  }
  return same_irq(&ta->irq[0], &tb->irq[0]) && same_irq(&ta->irq[1], &tb->irq[1]);
}

static void expect_same(const avr_t *a, const avr_t *b, unsigned program, unsigned step, uint16_t word) {
  if (!same_interrupts(a, b)) {
    fail_msg("program %u step %u, word %04x: the interrupt tables differ", program, step, word);
  }
  const bool same = a->pc == b->pc && a->cycle == b->cycle && a->state == b->state &&
                    a->interrupt_state == b->interrupt_state && memcmp(a->sreg, b->sreg, 8) == 0 &&
                    a->run_cycle_count == b->run_cycle_count && memcmp(a->data, b->data, a->ramend + 1u) == 0 &&
                    memcmp(a->flash, b->flash, a->flashend + 1u) == 0;
  if (!same) {
    unsigned first_data = 0;
    while (first_data <= a->ramend && a->data[first_data] == b->data[first_data]) {
      first_data++;
    }
    fail_msg("program %u step %u, word %04x: simavr pc %04x cycle %llu state %d int %d | fast pc %04x cycle %llu "
             "state %d int %d; first differing data byte 0x%x (%02x/%02x); SREG %s",
             program, step, word, a->pc, (unsigned long long)a->cycle, a->state, a->interrupt_state, b->pc,
             (unsigned long long)b->cycle, b->state, b->interrupt_state, first_data,
             first_data <= a->ramend ? a->data[first_data] : 0, first_data <= a->ramend ? b->data[first_data] : 0,
             memcmp(a->sreg, b->sreg, 8) == 0 ? "same" : "differs");
  }
}

static void test_random_programs_match_simavr(void **state) {
  (void)state;
  avr_t *a = make_mcu(), *b = make_mcu();
  fast_core_t *core = fast_core_new(b);
  assert_non_null(core);
  unsigned steps_run = 0, batches = 0;
  for (unsigned program = 0; program < PROGRAMS; program++) {
    avr_reset(a);
    avr_reset(b);
    simavr_extint_poll_off(a);
    simavr_extint_poll_off(b);
    fill_random(a, b, true);
    for (unsigned step = 0; step < STEPS_PER_PROGRAM; step++) {
      if (a->state == cpu_Sleeping) {
        a->state = b->state = cpu_Running;
      }
      if (a->state != cpu_Running) {
        break;
      }
      if (step % 97 == 96) { /* a flash word changes under the cache, near the PC */
        const uint32_t at = (a->pc + 2u * (rnd() % 8)) % (a->flashend + 1u);
        const uint16_t w = (uint16_t)rnd();
        a->flash[at & ~1u] = b->flash[at & ~1u] = (uint8_t)w;
        a->flash[at | 1u] = b->flash[at | 1u] = (uint8_t)(w >> 8);
      }
      keep_in_bounds(a, b);
      const uint16_t word = a->pc + 2 <= a->flashend ? word_at(a, a->pc) : 0;
      const sim_cycles_t until = rnd() % 2 ? 0 : a->cycle + rnd() % 40;
      const sim_cycles_t before = a->cycle;
      run_to(a, NULL, until);
      run_to(b, core, until);
      batches += a->cycle - before > 4;
      steps_run++;
      expect_same(a, b, program, step, word);
      if (simavr_reset_requested(a) || simavr_reset_requested(b)) {
        assert_true(simavr_reset_requested(a) && simavr_reset_requested(b));
        break;
      }
    }
  }
  print_message("%u steps (%u of them batches of several instructions) alike\n", steps_run, batches);
  assert_true(steps_run > PROGRAMS * 50u);
  assert_true(batches > steps_run / 20u);
  fast_core_free(core);
  avr_terminate(a);
  avr_terminate(b);
}

/* Every instruction word decodes to what simavr executes: the core stays in step through a
 * program of each word in turn, from the same state. */
static void test_every_word_matches_simavr(void **state) {
  (void)state;
  avr_t *a = make_mcu(), *b = make_mcu();
  fast_core_t *core = fast_core_new(b);
  assert_non_null(core);
  for (uint32_t w = 0; w <= 0xffff; w++) {
    avr_reset(a);
    avr_reset(b);
    simavr_extint_poll_off(a);
    simavr_extint_poll_off(b);
    fill_random(a, b, false);
    a->pc = b->pc = 0x1000;
    a->flash[0x1000] = b->flash[0x1000] = (uint8_t)w;
    a->flash[0x1001] = b->flash[0x1001] = (uint8_t)(w >> 8);
    keep_in_bounds(a, b);
    simavr_end_batches_at_timer_changes(a);
    simavr_end_batches_at_timer_changes(b);
    simavr_step_core(a, NULL, 0);
    simavr_step_core(b, core, 0);
    expect_same(a, b, 0, w, (uint16_t)w);
  }
  fast_core_free(core);
  avr_terminate(a);
  avr_terminate(b);
}

/* Near the flash's end, where the next PC can lie past it (the fast core tests the PC there
 * only): every word in each of the last three flash words, the others random, run in batches
 * until the core crashes off the flash or the batch ends. Branches, skips and two-word
 * instructions reach past the end from there. */
static void test_the_flash_end_matches_simavr(void **state) {
  (void)state;
  avr_t *a = make_mcu(), *b = make_mcu();
  fast_core_t *core = fast_core_new(b);
  assert_non_null(core);
  unsigned crashed = 0;
  for (uint32_t w = 0; w <= 0xffff; w++) {
    avr_reset(a);
    avr_reset(b);
    simavr_extint_poll_off(a);
    simavr_extint_poll_off(b);
    fill_random(a, b, false);
    const uint32_t last = a->flashend - 1u, at = last - 2u * (w % 3u);
    for (uint32_t pc = last - 4u; pc <= last + 4u; pc++) {
      a->flash[pc] = b->flash[pc] = (uint8_t)rnd();
    }
    a->flash[at] = b->flash[at] = (uint8_t)w;
    a->flash[at + 1] = b->flash[at + 1] = (uint8_t)(w >> 8);
    a->pc = b->pc = at - 2u * (rnd() % 2u);
    keep_in_bounds(a, b);
    for (unsigned step = 0; step < 4 && a->state == cpu_Running; step++) {
      const sim_cycles_t until = a->cycle + 1u + rnd() % 12u;
      run_to(a, NULL, until);
      run_to(b, core, until);
      expect_same(a, b, 1, w, (uint16_t)w);
    }
    crashed += a->state == cpu_Crashed;
  }
  print_message("%u of 65536 programs at the flash's end ran off it\n", crashed);
  assert_true(crashed > 65536u / 4u);
  fast_core_free(core);
  avr_terminate(a);
  avr_terminate(b);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_every_word_matches_simavr),
      cmocka_unit_test(test_the_flash_end_matches_simavr),
      cmocka_unit_test(test_random_programs_match_simavr),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
