/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "fast_core.h"
#include "fast_core_flags.h"
#include "fast_interrupts.h"

#include <endian.h>
#include <stdlib.h>
#include <string.h>

#include <sim_avr.h>
#include <sim_core.h>
#include <sim_cycle_timers.h>
#include <sim_interrupts.h>
#include <sim_io.h>
#include <sim_irq.h>
#include <sim_regbit.h>
#include <avr_flash.h>
#include <avr_watchdog.h>

/* ---- decoded instructions ---- */

/* One handler per instruction form; operands are pre-extracted by decode(). */
typedef enum {
  OP_NOP,
  OP_INVALID,
  OP_ADD, OP_ADC, OP_SUB, OP_SBC, OP_CP, OP_CPC, OP_CPSE,
  OP_AND, OP_OR, OP_EOR, OP_MOV, OP_MOVW,
  OP_MUL, OP_MULS, OP_MULSU, OP_FMUL, OP_FMULS, OP_FMULSU,
  OP_CPI, OP_SBCI, OP_SUBI, OP_ORI, OP_ANDI, OP_LDI,
  OP_LDD, OP_STD,                   /* d, base pointer register in x, displacement in r */
  OP_LD_INC, OP_LD_DEC, OP_ST_INC, OP_ST_DEC, /* d, pointer register in x */
  OP_LDS, OP_STS,
  OP_LPM_R0, OP_LPM, OP_LPM_INC, OP_ELPM_R0, OP_ELPM, OP_ELPM_INC,
  OP_PUSH, OP_POP,
  OP_COM, OP_NEG, OP_SWAP, OP_INC, OP_DEC, OP_ASR, OP_LSR, OP_ROR,
  OP_ADIW, OP_SBIW,
  OP_BSET, OP_BCLR, OP_BLD, OP_BST,
  OP_IN, OP_OUT, OP_CBI, OP_SBI, OP_SBIC, OP_SBIS,
  OP_SBRC, OP_SBRS, OP_BRBS, OP_BRBC,
  OP_RJMP, OP_RCALL, OP_JMP, OP_CALL, OP_IJMP, OP_ICALL, OP_EIJMP, OP_EICALL, OP_RET, OP_RETI,
  OP_SLEEP, OP_BREAK, OP_WDR, OP_SPM,
  OP_COUNT
} fc_op_t;

/* The interpreter's handlers: one per fc_op_t, and near_end (see run()). */
#define HANDLER_NEAR_END OP_COUNT
#define HANDLERS (OP_COUNT + 1)

typedef struct {
  const void *handler; /* the interpreter's label for op */
  uint16_t word;       /* the flash word this entry was decoded from */
  uint8_t op;          /* fc_op_t */
  uint8_t d;           /* destination register, I/O data address, pointer pair */
  uint8_t r;           /* source register, bit number, displacement */
  uint8_t x;           /* immediate byte, bit mask, pointer register */
  uint16_t k;          /* RJMP/RCALL: target (byte address); BRBS/BRBC: signed byte offset from the branch */
} fc_insn_t;

_Static_assert(sizeof(fc_insn_t) == 16, "code[pc / 2] is found as code + pc * 8");

struct fast_core {
  uint32_t words;   /* flash words covered */
  fc_insn_t *code;  /* one entry per flash word */
};

/* The data-space addresses simavr 1.6's core hands to its I/O table (32 .. 31 + MAX_IOs, its
 * _avr_set_ram/_avr_get_ram bound), SRAM included on parts whose RAM starts below it. */
#define IO_END (MAX_IOs + 31)

static inline uint16_t flash_word(const uint8_t *flash, uint32_t pc) {
  uint16_t w;
  memcpy(&w, flash + pc, sizeof(w));
  return le16toh(w);
}

static inline bool next_is_two_words(const uint8_t *flash, uint32_t pc) {
  const uint16_t o = flash_word(flash, pc) & 0xfc0f;
  return o == 0x9200 || o == 0x9000 || o == 0x940c || o == 0x940d || o == 0x940e || o == 0x940f;
}

/* Decodes the word at byte address pc into e, as simavr 1.6's avr_run_one() dispatches it
 * (the same masks in the same order, so every word maps to what that core would execute). */
static void decode_op(const avr_t *avr, fc_insn_t *e, uint32_t pc, uint16_t w) {
  memset(e, 0, sizeof(*e));
  e->word = w;
  e->op = OP_INVALID;
  const uint8_t d5 = (w >> 4) & 0x1f;
  const uint8_t r5 = (uint8_t)(((w >> 5) & 0x10) | (w & 0xf));
  const uint8_t h4 = (uint8_t)(16 + ((w >> 4) & 0xf));
  const uint8_t k8 = (uint8_t)(((w & 0x0f00) >> 4) | (w & 0xf));
  switch (w & 0xf000) {
  case 0x0000:
    if (w == 0) {
      e->op = OP_NOP;
      return;
    }
    e->d = d5;
    e->r = r5;
    switch (w & 0xfc00) {
    case 0x0400: e->op = OP_CPC; return;
    case 0x0c00: e->op = OP_ADD; return;
    case 0x0800: e->op = OP_SBC; return;
    default: break;
    }
    switch (w & 0xff00) {
    case 0x0100:
      e->op = OP_MOVW;
      e->d = (uint8_t)(((w >> 4) & 0xf) << 1);
      e->r = (uint8_t)((w & 0xf) << 1);
      return;
    case 0x0200:
      e->op = OP_MULS;
      e->d = (uint8_t)(16 + ((w >> 4) & 0xf));
      e->r = (uint8_t)(16 + (w & 0xf));
      return;
    case 0x0300: {
      static const uint8_t forms[4] = {OP_MULSU, OP_FMUL, OP_FMULS, OP_FMULSU};
      e->op = forms[((w >> 6) & 2) | ((w >> 3) & 1)];
      e->d = (uint8_t)(16 + ((w >> 4) & 0x7));
      e->r = (uint8_t)(16 + (w & 0x7));
      return;
    }
    default: e->op = OP_INVALID; return;
    }
  case 0x1000:
    e->d = d5;
    e->r = r5;
    switch (w & 0xfc00) {
    case 0x1800: e->op = OP_SUB; return;
    case 0x1000: e->op = OP_CPSE; return;
    case 0x1400: e->op = OP_CP; return;
    default: e->op = OP_ADC; return; /* 0x1c00 */
    }
  case 0x2000:
    e->d = d5;
    e->r = r5;
    switch (w & 0xfc00) {
    case 0x2000: e->op = OP_AND; return;
    case 0x2400: e->op = OP_EOR; return;
    case 0x2800: e->op = OP_OR; return;
    default: e->op = OP_MOV; return; /* 0x2c00 */
    }
  case 0x3000: e->op = OP_CPI; e->d = h4; e->x = k8; return;
  case 0x4000: e->op = OP_SBCI; e->d = h4; e->x = k8; return;
  case 0x5000: e->op = OP_SUBI; e->d = h4; e->x = k8; return;
  case 0x6000: e->op = OP_ORI; e->d = h4; e->x = k8; return;
  case 0x7000: e->op = OP_ANDI; e->d = h4; e->x = k8; return;
  case 0x8000:
  case 0xa000:
    e->op = (w & 0x0200) ? OP_STD : OP_LDD;
    e->d = d5;
    e->r = (uint8_t)(((w & 0x2000) >> 8) | ((w & 0x0c00) >> 7) | (w & 0x7));
    e->x = (w & 0x0008) ? R_YL : R_ZL;
    return;
  case 0x9000:
    if ((w & 0xff0f) == 0x9408) {
      e->op = (w & 0x0080) ? OP_BCLR : OP_BSET;
      e->r = (w >> 4) & 7;
      return;
    }
    switch (w) {
    case 0x9588: e->op = OP_SLEEP; return;
    case 0x9598: e->op = OP_BREAK; return;
    case 0x95a8: e->op = OP_WDR; return;
    case 0x95e8: e->op = OP_SPM; return;
    case 0x9409: e->op = OP_IJMP; return;
    case 0x9419: e->op = OP_EIJMP; return;
    case 0x9509: e->op = OP_ICALL; return;
    case 0x9519: e->op = OP_EICALL; return;
    case 0x9518: e->op = OP_RETI; return;
    case 0x9508: e->op = OP_RET; return;
    case 0x95c8: e->op = OP_LPM_R0; return;
    case 0x95d8: e->op = OP_ELPM_R0; return;
    default: break;
    }
    e->d = d5;
    switch (w & 0xfe0f) {
    case 0x9000: e->op = OP_LDS; return;
    case 0x9004: e->op = OP_LPM; return;
    case 0x9005: e->op = OP_LPM_INC; return;
    case 0x9006: e->op = OP_ELPM; return;
    case 0x9007: e->op = OP_ELPM_INC; return;
    case 0x900c: e->op = OP_LDD; e->x = R_XL; return; /* LD Rd, X: no displacement */
    case 0x900d: e->op = OP_LD_INC; e->x = R_XL; return;
    case 0x900e: e->op = OP_LD_DEC; e->x = R_XL; return;
    case 0x920c: e->op = OP_STD; e->x = R_XL; return;
    case 0x920d: e->op = OP_ST_INC; e->x = R_XL; return;
    case 0x920e: e->op = OP_ST_DEC; e->x = R_XL; return;
    case 0x9009: e->op = OP_LD_INC; e->x = R_YL; return;
    case 0x900a: e->op = OP_LD_DEC; e->x = R_YL; return;
    case 0x9209: e->op = OP_ST_INC; e->x = R_YL; return;
    case 0x920a: e->op = OP_ST_DEC; e->x = R_YL; return;
    case 0x9200: e->op = OP_STS; return;
    case 0x9001: e->op = OP_LD_INC; e->x = R_ZL; return;
    case 0x9002: e->op = OP_LD_DEC; e->x = R_ZL; return;
    case 0x9201: e->op = OP_ST_INC; e->x = R_ZL; return;
    case 0x9202: e->op = OP_ST_DEC; e->x = R_ZL; return;
    case 0x900f: e->op = OP_POP; return;
    case 0x920f: e->op = OP_PUSH; return;
    case 0x9400: e->op = OP_COM; return;
    case 0x9401: e->op = OP_NEG; return;
    case 0x9402: e->op = OP_SWAP; return;
    case 0x9403: e->op = OP_INC; return;
    case 0x9405: e->op = OP_ASR; return;
    case 0x9406: e->op = OP_LSR; return;
    case 0x9407: e->op = OP_ROR; return;
    case 0x940a: e->op = OP_DEC; return;
    case 0x940c:
    case 0x940d: e->op = OP_JMP; return;
    case 0x940e:
    case 0x940f: e->op = OP_CALL; return;
    default: break;
    }
    switch (w & 0xff00) {
    case 0x9600:
    case 0x9700:
      e->op = (w & 0x0100) ? OP_SBIW : OP_ADIW;
      e->d = (uint8_t)(24 + ((w >> 3) & 0x6));
      e->x = (uint8_t)(((w & 0x00c0) >> 2) | (w & 0xf));
      return;
    case 0x9800:
    case 0x9900:
    case 0x9a00:
    case 0x9b00: {
      static const uint8_t forms[4] = {OP_CBI, OP_SBIC, OP_SBI, OP_SBIS};
      e->op = forms[(w >> 8) & 3];
      e->d = (uint8_t)(((w >> 3) & 0x1f) + 32);
      e->x = (uint8_t)(1u << (w & 0x7));
      return;
    }
    default: break;
    }
    if ((w & 0xfc00) == 0x9c00) {
      e->op = OP_MUL;
      e->r = r5;
      return;
    }
    e->op = OP_INVALID;
    return;
  case 0xb000:
    e->op = (w & 0x0800) ? OP_OUT : OP_IN;
    e->d = d5;
    e->x = (uint8_t)(((((w >> 9) & 3) << 4) | (w & 0xf)) + 32);
    return;
  case 0xc000:
  case 0xd000: {
    const int16_t o = (int16_t)((int16_t)((w << 4) & 0xffff) >> 3);
    e->op = (w & 0x1000) ? OP_RCALL : OP_RJMP;
    e->k = (uint16_t)((pc + 2 + (uint32_t)(int32_t)o) % (avr->flashend + 1));
    return;
  }
  case 0xe000: e->op = OP_LDI; e->d = h4; e->x = k8; return;
  default: /* 0xf000 */
    switch (w & 0xfe00) {
    case 0xf000:
    case 0xf200:
    case 0xf400:
    case 0xf600: {
      const int16_t o = (int16_t)((int16_t)(w << 6) >> 9);
      e->op = (w & 0x0400) ? OP_BRBC : OP_BRBS;
      e->r = w & 7;
      e->k = (uint16_t)(2 + o * 2); /* signed: added to the branch's address */
      return;
    }
    case 0xf800: e->op = OP_BLD; break;
    case 0xfa00: e->op = OP_BST; break;
    case 0xfc00: e->op = OP_SBRC; break;
    default: e->op = OP_SBRS; break; /* 0xfe00 */
    }
    e->d = d5;
    e->r = w & 7;
    e->x = (uint8_t)(1u << (w & 7));
    return;
  }
}

/* The interpreter's handler labels by fc_op_t (run(NULL, NULL, &table) hands them out). */
typedef const void *const *fc_handlers_t;

/* The next PC of the entry at pc may lie past the flash: it is among the last three words
 * (a skip over a two-word instruction goes 6 bytes on), or a branch whose target lies outside. */
static bool near_end(const avr_t *avr, const fc_insn_t *e, uint32_t pc) {
  if (pc + 6 >= avr->flashend) {
    return true;
  }
  return (e->op == OP_BRBS || e->op == OP_BRBC) && pc + (uint32_t)(int32_t)(int16_t)e->k >= avr->flashend;
}

static void decode(const avr_t *avr, fc_insn_t *e, uint32_t pc, uint16_t w, fc_handlers_t handlers) {
  decode_op(avr, e, pc, w);
  e->handler = handlers[near_end(avr, e, pc) ? HANDLER_NEAR_END : e->op];
}

/* ---- what leaves the core: simavr's I/O handlers and IRQs, SREG, its crash ---- */

static inline void sreg_set(avr_t *avr, uint8_t flag, uint8_t v) {
  if (flag == S_I) {
    if (v) {
      if (!avr->sreg[S_I]) {
        avr->interrupt_state = -2; /* SEI: the next instruction runs before an interrupt */
      }
    } else {
      avr->interrupt_state = 0;
    }
  }
  avr->sreg[flag] = v;
}

static void raise_io_irqs(avr_irq_t *irq, uint8_t v) {
  fast_irq_raise(irq + AVR_IOMEM_IRQ_ALL, v);
  for (int i = 0; i < 8; i++) {
    fast_irq_raise(irq + i, (v >> i) & 1);
  }
}

/* A store the core does itself: a register, SRAM, or an I/O address with neither a write
 * handler nor IRQs (SPL/SPH, GPIORs, the SRAM simavr's I/O table covers). */
static inline bool store_is_plain(const avr_t *avr, uint16_t addr, uint16_t ramend) {
  if (addr < 32) {
    return true;
  }
  if (addr < IO_END) {
    const avr_io_addr_t io = AVR_DATA_TO_IO(addr);
    return addr != R_SREG && !avr->io[io].w.c && !avr->io[io].irq;
  }
  return addr <= ramend;
}

static inline bool load_is_plain(const avr_t *avr, uint16_t addr, uint16_t ramend) {
  if (addr > ramend) {
    return false;
  }
  if (addr < 32 || addr >= IO_END) {
    return true;
  }
  const avr_io_addr_t io = AVR_DATA_TO_IO(addr);
  return addr != R_SREG && !avr->io[io].r.c && !avr->io[io].irq;
}

/* A write to SREG with no I/O handler or IRQ on it, as simavr's _avr_set_r does it: the byte,
 * the mirror (flag by flag, only I has a side effect: SEI's delay, or no interrupt), the byte. */
static inline void sreg_write(avr_t *avr, uint8_t v) {
  if (v & (1u << S_I)) {
    if (!avr->sreg[S_I]) {
      avr->interrupt_state = -2;
    }
  } else {
    avr->interrupt_state = 0;
  }
  memcpy(avr->sreg, &fc_flags.sreg[v], 8);
  avr->data[R_SREG] = v;
}

static inline bool sreg_write_is_plain(const avr_t *avr) {
  const avr_io_addr_t io = AVR_DATA_TO_IO(R_SREG);
  return !avr->io[io].w.c && !avr->io[io].irq;
}

/* A read of SREG: its value from the mirror (simavr: a flag byte above 1 reads as 0). */
static inline uint8_t sreg_read(avr_t *avr) {
  uint64_t bytes;
  memcpy(&bytes, avr->sreg, 8);
  uint8_t v;
  if (__builtin_expect((bytes & ~0x0101010101010101ull) == 0, 1)) {
    v = (uint8_t)((bytes * 0x0102040810204080ull) >> 56); /* bit i = byte i */
  } else {
    v = 0;
    for (int i = 0; i < 8; i++) {
      v |= (uint8_t)((avr->sreg[i] == 1) << i);
    }
  }
  avr->data[R_SREG] = v;
  return v;
}

/* simavr 1.6's _avr_set_ram for the other stores: SREG (its mirror and the interrupt state),
 * an I/O handler and the register's IRQs, or past RAM (a logged crash). */
static __attribute__((noinline)) void store_slow(avr_t *avr, uint16_t addr, uint8_t v) {
  if (addr >= IO_END) {
    avr_core_watch_write(avr, addr, v);
    return;
  }
  if (addr == R_SREG) {
    avr->data[R_SREG] = v;
    for (uint8_t i = 0; i < 8; i++) {
      sreg_set(avr, i, (v >> i) & 1);
    }
  }
  const avr_io_addr_t io = AVR_DATA_TO_IO(addr);
  if (avr->io[io].w.c) {
    avr->io[io].w.c(avr, addr, v, avr->io[io].w.param);
  } else {
    avr->data[addr] = v;
  }
  if (avr->io[io].irq) {
    raise_io_irqs(avr->io[io].irq, v);
  }
}

/* simavr 1.6's _avr_get_ram for the other loads: SREG from its mirror, an I/O handler and the
 * register's IRQs, or past RAM (a logged crash). */
static __attribute__((noinline)) uint8_t load_slow(avr_t *avr, uint16_t addr) {
  if (addr == R_SREG) {
    uint8_t s = 0;
    for (int i = 0; i < 8; i++) {
      s |= (uint8_t)((avr->sreg[i] == 1) << i); /* simavr: a flag byte above 1 reads as 0 */
    }
    avr->data[R_SREG] = s;
  } else if (addr > 31 && addr < IO_END) {
    const avr_io_addr_t io = AVR_DATA_TO_IO(addr);
    if (avr->io[io].r.c) {
      avr->data[addr] = avr->io[io].r.c(avr, addr, avr->io[io].r.param);
    }
    if (avr->io[io].irq) {
      raise_io_irqs(avr->io[io].irq, avr->data[addr]);
    }
  }
  if (addr > avr->ramend) {
    return avr_core_watch_read(avr, addr);
  }
  return avr->data[addr];
}

/* ---- flags (fast_core_flags.h) ---- */

static inline void flags_word(uint8_t *s, uint16_t res, uint8_t v, uint8_t c) {
  const uint8_t n = (res >> 15) & 1;
  s[S_V] = v;
  s[S_C] = c;
  s[S_Z] = res == 0;
  s[S_N] = n;
  s[S_S] = n ^ v;
}

static void invalid_opcode(avr_t *avr, uint32_t pc) {
  AVR_LOG(avr, LOG_ERROR, "CORE: *** %04x: invalid opcode %04x, SP %04x\n", pc, flash_word(avr->flash, pc),
          avr->data[R_SPL] | (avr->data[R_SPH] << 8));
}

/* ---- interrupts: entry and return, as simavr 1.6's sim_interrupts.c ---- */

/* The return address of an interrupt: simavr's _avr_push_addr with this core's stores. */
static void push_return(avr_t *avr, uint32_t pc) {
  const uint16_t ramend = avr->ramend;
  uint16_t sp = (uint16_t)(avr->data[R_SPL] | (avr->data[R_SPH] << 8));
  const uint32_t word = pc >> 1;
  const uint8_t bytes[2] = {(uint8_t)word, (uint8_t)(word >> 8)};
  for (int i = 0; i < 2; i++, sp--) {
    if (store_is_plain(avr, sp, ramend)) {
      avr->data[sp] = bytes[i];
    } else {
      store_slow(avr, sp, bytes[i]);
    }
  }
  const uint8_t sp_bytes[2] = {(uint8_t)sp, (uint8_t)(sp >> 8)};
  for (int i = 0; i < 2; i++) {
    const uint16_t reg = (uint16_t)(R_SPL + i);
    if (store_is_plain(avr, reg, ramend)) {
      avr->data[reg] = sp_bytes[i];
    } else {
      store_slow(avr, reg, sp_bytes[i]);
    }
  }
}

void fast_core_enter_interrupt(avr_t *avr) {
  avr_int_table_p table = &avr->interrupts;
  const int count = avr_int_pending_get_read_size(&table->pending);
  int lowest = 0xff, at = 0;
  for (int i = 0; i < count; i++) {
    const avr_int_vector_t *v = avr_int_pending_read_at(&table->pending, (uint16_t)i);
    if (v->vector < lowest) {
      lowest = v->vector;
      at = i;
    }
  }
  avr_int_vector_t *vector = avr_int_pending_read_at(&table->pending, (uint16_t)at);
  /* The vector leaves the queue: the one at its front takes its slot (the slot as it was
   * before the read, as Debian's build of simavr 1.6 computes it). */
  const unsigned slot = (table->pending.read + (unsigned)at) % avr_int_pending_fifo_size;
  table->pending.buffer[slot] = avr_int_pending_read(&table->pending);
  fast_irq_raise(table->irq + AVR_INT_IRQ_PENDING, (uint32_t)fast_pending_any(avr));
  if (!avr_regbit_get(avr, vector->enable) || !vector->pending) {
    vector->pending = 0; /* disabled or cleared meanwhile */
    avr->interrupt_state = (int8_t)fast_pending_any(avr);
    return;
  }
  push_return(avr, avr->pc);
  sreg_set(avr, S_I, 0);
  avr->pc = (avr_flashaddr_t)(vector->vector * avr->vector_size);
  fast_irq_raise(vector->irq + AVR_INT_IRQ_RUNNING, 1);
  fast_irq_raise(table->irq + AVR_INT_IRQ_RUNNING, vector->vector);
  if (table->running_ptr == sizeof(table->running) / sizeof(table->running[0])) {
    AVR_LOG(avr, LOG_ERROR, "%s: nested interrupts past simavr's stack of them\n", __func__);
  } else {
    table->running[table->running_ptr++] = vector;
  }
  fast_clear_interrupt(avr, vector);
}

/* avr_interrupt_reti: the running interrupt ends. */
static void interrupt_return(avr_t *avr) {
  avr_int_table_p table = &avr->interrupts;
  if (table->running_ptr) {
    avr_int_vector_t *vector = table->running[--table->running_ptr];
    fast_irq_raise(vector->irq + AVR_INT_IRQ_RUNNING, 0);
  }
  fast_irq_raise(table->irq + AVR_INT_IRQ_RUNNING, table->running_ptr > 0 ? table->running[table->running_ptr - 1]->vector : 0);
  fast_irq_raise(table->irq + AVR_INT_IRQ_PENDING, (uint32_t)fast_pending_any(avr));
}

/* ---- the interpreter ----
 * The PC and the cycle counter live in locals while the core runs plain instructions, and the
 * batch's remaining cycles as the cycle it ends at (end = cycle + run_cycle_count): an
 * instruction continues the batch when the cycle after it is below limit, which is end
 * (simavr's test: run_cycle_count > the instruction's cycles) or 0. SYNC() writes them back
 * before anything outside the core runs (an I/O handler, simavr's interrupt and watchdog code,
 * a log), which may read them and change the remaining cycles (a cycle timer registered), the
 * run state or the interrupt state; RESYNC() reads them back and sets limit to 0 (STOP()), so
 * that the instruction ends at check:, where the run and interrupt state are tested as simavr's
 * loop tests them after every instruction. A plain instruction can change neither.
 *
 * Each handler ends by dispatching the next instruction itself (NEXT): its cycles and size are
 * constants there, and pc holds the instruction's own address until then (SYNC hands simavr
 * that address, as avr_run_one does). simavr checks the PC against the flash's end before every
 * instruction; here only where it can leave the flash: at a jump, call or return to a computed
 * address (NEXT_FAR), and at the entries near the flash's end or with a branch target outside
 * it, which decode() gives the handler near_end: they end at check:, which tests the PC. */

static uint32_t run(fast_core_t *core, avr_t *avr, avr_cycle_count_t until, fc_handlers_t *table) {
  static const void *const handlers[HANDLERS] = {
      [OP_NOP] = &&op_nop, [OP_INVALID] = &&op_invalid,
      [OP_ADD] = &&op_add, [OP_ADC] = &&op_adc, [OP_SUB] = &&op_sub, [OP_SBC] = &&op_sbc,
      [OP_CP] = &&op_cp, [OP_CPC] = &&op_cpc, [OP_CPSE] = &&op_cpse,
      [OP_AND] = &&op_and, [OP_OR] = &&op_or, [OP_EOR] = &&op_eor, [OP_MOV] = &&op_mov,
      [OP_MOVW] = &&op_movw,
      [OP_MUL] = &&op_mul, [OP_MULS] = &&op_muls, [OP_MULSU] = &&op_mulsu, [OP_FMUL] = &&op_fmul,
      [OP_FMULS] = &&op_fmuls, [OP_FMULSU] = &&op_fmulsu,
      [OP_CPI] = &&op_cpi, [OP_SBCI] = &&op_sbci, [OP_SUBI] = &&op_subi, [OP_ORI] = &&op_ori,
      [OP_ANDI] = &&op_andi, [OP_LDI] = &&op_ldi,
      [OP_LDD] = &&op_ldd, [OP_STD] = &&op_std,
      [OP_LD_INC] = &&op_ld_inc, [OP_LD_DEC] = &&op_ld_dec, [OP_ST_INC] = &&op_st_inc,
      [OP_ST_DEC] = &&op_st_dec,
      [OP_LDS] = &&op_lds, [OP_STS] = &&op_sts,
      [OP_LPM_R0] = &&op_lpm_r0, [OP_LPM] = &&op_lpm, [OP_LPM_INC] = &&op_lpm_inc,
      [OP_ELPM_R0] = &&op_elpm_r0, [OP_ELPM] = &&op_elpm, [OP_ELPM_INC] = &&op_elpm,
      [OP_PUSH] = &&op_push, [OP_POP] = &&op_pop,
      [OP_COM] = &&op_com, [OP_NEG] = &&op_neg, [OP_SWAP] = &&op_swap, [OP_INC] = &&op_inc,
      [OP_DEC] = &&op_dec, [OP_ASR] = &&op_asr, [OP_LSR] = &&op_lsr, [OP_ROR] = &&op_ror,
      [OP_ADIW] = &&op_adiw, [OP_SBIW] = &&op_sbiw,
      [OP_BSET] = &&op_bset, [OP_BCLR] = &&op_bclr, [OP_BLD] = &&op_bld, [OP_BST] = &&op_bst,
      [OP_IN] = &&op_in, [OP_OUT] = &&op_out, [OP_CBI] = &&op_cbi, [OP_SBI] = &&op_sbi,
      [OP_SBIC] = &&op_sbic, [OP_SBIS] = &&op_sbis,
      [OP_SBRC] = &&op_sbrc, [OP_SBRS] = &&op_sbrs, [OP_BRBS] = &&op_brbs, [OP_BRBC] = &&op_brbc,
      [OP_RJMP] = &&op_rjmp, [OP_RCALL] = &&op_rcall, [OP_JMP] = &&op_jmp, [OP_CALL] = &&op_call,
      [OP_IJMP] = &&op_ijmp, [OP_ICALL] = &&op_icall, [OP_EIJMP] = &&op_eijmp,
      [OP_EICALL] = &&op_eijmp, [OP_RET] = &&op_ret, [OP_RETI] = &&op_reti,
      [OP_SLEEP] = &&op_sleep, [OP_BREAK] = &&op_break, [OP_WDR] = &&op_wdr, [OP_SPM] = &&op_spm,
      [HANDLER_NEAR_END] = &&near_end,
  };
  if (table) {
    *table = handlers;
    return 0;
  }
  uint8_t *const data = avr->data;
  uint8_t *const s = avr->sreg;
  const uint8_t *const flash = avr->flash;
  fc_insn_t *const code = core->code;
  const uint16_t ramend = avr->ramend;
  const uint32_t flashend = avr->flashend;
  uint32_t pc = avr->pc;
  avr_cycle_count_t cycle = avr->cycle;
  avr_cycle_count_t end = cycle + avr->run_cycle_count;
  avr_cycle_count_t limit = 0; /* the first instruction ends at check:, as simavr's */
  unsigned cycles;             /* the last instruction's, on the way to check: */
  const fc_insn_t *e;

#define STOP() (limit = 0)
#define SYNC() (avr->pc = pc, avr->cycle = cycle, avr->run_cycle_count = end - cycle)
#define RESYNC() (cycle = avr->cycle, end = cycle + avr->run_cycle_count, limit = 0)
  /* Fetches the entry at pc (code[pc / 2]), decoded again when the flash word changed, and
   * runs its handler. */
#define DISPATCH()                                                                                                     \
  do {                                                                                                                 \
    e = (const fc_insn_t *)((const char *)code + (size_t)pc * (sizeof(fc_insn_t) / 2));                              \
    uint16_t w_;                                                                                                       \
    memcpy(&w_, flash + pc, sizeof(w_));                                                                               \
    if (__builtin_expect(e->word != le16toh(w_), 0)) {                                                                 \
      goto redecode;                                                                                                   \
    }                                                                                                                  \
    goto *e->handler;                                                                                                  \
  } while (0)
  /* The instruction took n cycles; the next one is `size` bytes on. */
#define NEXT(n, size)                                                                                                  \
  do {                                                                                                                 \
    cycle += (n);                                                                                                      \
    pc += (size);                                                                                                      \
    if (__builtin_expect(cycle < limit, 1)) {                                                                          \
      DISPATCH();                                                                                                      \
    }                                                                                                                  \
    cycles = (n);                                                                                                      \
    goto check;                                                                                                        \
  } while (0)
  /* The instruction took n cycles; the next one is at target, which may lie past the flash. */
#define NEXT_FAR(n, target)                                                                                            \
  do {                                                                                                                 \
    cycle += (n);                                                                                                      \
    pc = (target);                                                                                                     \
    if (__builtin_expect(cycle < limit && pc < flashend, 1)) {                                                         \
      DISPATCH();                                                                                                      \
    }                                                                                                                  \
    cycles = (n);                                                                                                      \
    goto check;                                                                                                        \
  } while (0)
#define STORE(addr_expr, v_expr)                                                                                       \
  do {                                                                                                                 \
    const uint16_t a_ = (uint16_t)(addr_expr);                                                                         \
    const uint8_t v_ = (uint8_t)(v_expr);                                                                              \
    if (store_is_plain(avr, a_, ramend)) {                                                                             \
      data[a_] = v_;                                                                                                   \
    } else if (a_ == R_SREG && sreg_write_is_plain(avr)) {                                                             \
      sreg_write(avr, v_);                                                                                             \
      STOP(); /* the interrupt state may change */                                                                     \
    } else {                                                                                                           \
      SYNC();                                                                                                          \
      store_slow(avr, a_, v_);                                                                                         \
      RESYNC();                                                                                                        \
    }                                                                                                                  \
  } while (0)
#define LOAD(dst, addr_expr)                                                                                           \
  do {                                                                                                                 \
    const uint16_t a_ = (uint16_t)(addr_expr);                                                                         \
    if (load_is_plain(avr, a_, ramend)) {                                                                              \
      (dst) = data[a_];                                                                                                \
    } else if (a_ == R_SREG) {                                                                                         \
      (dst) = sreg_read(avr);                                                                                          \
    } else {                                                                                                           \
      SYNC();                                                                                                          \
      (dst) = load_slow(avr, a_);                                                                                      \
      RESYNC();                                                                                                        \
    }                                                                                                                  \
  } while (0)
#define SP() ((uint16_t)(data[R_SPL] | (data[R_SPH] << 8)))
#define SET_SP(v)                                                                                                      \
  do {                                                                                                                 \
    const uint16_t sp_ = (uint16_t)(v);                                                                                \
    STORE(R_SPL, sp_);                                                                                                 \
    STORE(R_SPH, sp_ >> 8);                                                                                            \
  } while (0)
  /* A 2-byte return address (fast_core_new refuses 3-byte cores): low byte at SP, high below. */
#define PUSH_PC(return_pc)                                                                                             \
  do {                                                                                                                 \
    const uint16_t sp_pc_ = SP();                                                                                      \
    const uint32_t word_ = (return_pc) >> 1;                                                                           \
    STORE(sp_pc_, word_);                                                                                              \
    STORE(sp_pc_ - 1, word_ >> 8);                                                                                     \
    SET_SP(sp_pc_ - 2);                                                                                                \
  } while (0)
#define POP_PC(dst)                                                                                                    \
  do {                                                                                                                 \
    const uint16_t sp_pc_ = SP();                                                                                      \
    uint8_t hi_, lo_;                                                                                                  \
    LOAD(hi_, sp_pc_ + 1);                                                                                             \
    LOAD(lo_, sp_pc_ + 2);                                                                                             \
    SET_SP(sp_pc_ + 2);                                                                                                \
    (dst) = (uint32_t)((hi_ << 8) | lo_) << 1;                                                                         \
  } while (0)
#define POINTER(reg) ((uint16_t)(data[reg] | (data[(reg) + 1] << 8)))

  if (__builtin_expect(pc >= flashend, 0)) {
    goto off_the_flash;
  }
  DISPATCH();

redecode: /* the flash changed under the entry */
  decode(avr, &code[pc / 2], pc, flash_word(flash, pc), handlers);
  goto *e->handler;
near_end: /* the next PC may lie past the flash: check: tests it */
  STOP();
  goto *handlers[e->op];

op_nop:
  NEXT(1, 2);
op_invalid:
  SYNC();
  invalid_opcode(avr, pc);
  RESYNC();
  NEXT(1, 2);
  /* ADD/ADC, SUB/SBC/CP/CPC and their immediate forms, AND/OR/EOR and theirs: rr is the
   * source register's byte or the immediate; with_carry adds or subtracts C (and keeps Z set
   * only while the result is zero, for SBC/CPC/SBCI); store: the result goes to Rd. */
#define ADD_FORM(rr_value, with_carry)                                                                                 \
  {                                                                                                                    \
    uint32_t index;                                                                                                    \
    const uint8_t res = (with_carry) ? fc_add8(data[e->d], (rr_value), s[S_C], &index)                                \
                                     : fc_add8_nc(data[e->d], (rr_value), &index);                                     \
    data[e->d] = res;                                                                                                  \
    fc_sreg_merge(s, FC_ARITH, fc_flags.arith[index]);                                                                 \
    NEXT(1, 2);                                                                                                        \
  }
#define SUB_FORM(rr_value, with_carry, store)                                                                          \
  {                                                                                                                    \
    uint32_t index;                                                                                                    \
    const uint8_t res = (with_carry) ? fc_sub8(data[e->d], (rr_value), s[S_C], &index)                                \
                                     : fc_sub8_nc(data[e->d], (rr_value), &index);                                     \
    if (store) {                                                                                                       \
      data[e->d] = res;                                                                                                \
    }                                                                                                                  \
    if (with_carry) {                                                                                                  \
      fc_sreg_merge_keep_zero(s, fc_flags.arith[index]);                                                               \
    } else {                                                                                                           \
      fc_sreg_merge(s, FC_ARITH, fc_flags.arith[index]);                                                               \
    }                                                                                                                  \
    NEXT(1, 2);                                                                                                        \
  }
#define LOGIC_FORM(operator, rr_value)                                                                                 \
  {                                                                                                                    \
    const uint8_t res = data[e->d] operator(rr_value);                                                                 \
    data[e->d] = res;                                                                                                  \
    fc_sreg_merge(s, FC_ZNVS, fc_flags.logic[res]);                                                                    \
    NEXT(1, 2);                                                                                                        \
  }
op_add:
  ADD_FORM(data[e->r], false)
op_adc:
  ADD_FORM(data[e->r], true)
op_sub:
  SUB_FORM(data[e->r], false, true)
op_sbc:
  SUB_FORM(data[e->r], true, true)
op_cp:
  SUB_FORM(data[e->r], false, false)
op_cpc:
  SUB_FORM(data[e->r], true, false)
op_cpse:
  if (data[e->d] == data[e->r]) {
    goto skip;
  }
  NEXT(1, 2);
op_and:
  LOGIC_FORM(&, data[e->r])
op_or:
  LOGIC_FORM(|, data[e->r])
op_eor:
  LOGIC_FORM(^, data[e->r])
op_mov:
  data[e->d] = data[e->r];
  NEXT(1, 2);
op_movw: {
  const uint8_t lo = data[e->r], hi = data[e->r + 1];
  data[e->d] = lo;
  data[e->d + 1] = hi;
  NEXT(1, 2);
}
op_mul: {
  const uint16_t res = (uint16_t)(data[e->d] * data[e->r]);
  data[0] = (uint8_t)res;
  data[1] = (uint8_t)(res >> 8);
  s[S_Z] = res == 0;
  s[S_C] = (res >> 15) & 1;
  NEXT(2, 2);
}
op_muls: {
  const int16_t res = (int16_t)((int8_t)data[e->r] * (int8_t)data[e->d]);
  data[0] = (uint8_t)res;
  data[1] = (uint8_t)((uint16_t)res >> 8);
  s[S_C] = ((uint16_t)res >> 15) & 1;
  s[S_Z] = res == 0;
  NEXT(2, 2);
}
  /* The products as simavr 1.6 forms them: a 16-bit signed result, C from its bit 15 before
   * the fractional shift, Z after it. */
#define MUL_FORM(product, shift)                                                                                       \
  {                                                                                                                    \
    int16_t res = (int16_t)(product);                                                                                  \
    const uint8_t c = ((uint16_t)res >> 15) & 1;                                                                       \
    res = (int16_t)(uint16_t)((uint16_t)res << (shift));                                                               \
    data[0] = (uint8_t)res;                                                                                            \
    data[1] = (uint8_t)((uint16_t)res >> 8);                                                                           \
    s[S_C] = c;                                                                                                        \
    s[S_Z] = res == 0;                                                                                                 \
    NEXT(2, 2);                                                                                                        \
  }
op_mulsu:
  MUL_FORM((uint8_t)data[e->r] * (int8_t)data[e->d], 0)
op_fmul:
  MUL_FORM((uint8_t)data[e->r] * (uint8_t)data[e->d], 1)
op_fmuls:
  MUL_FORM((int8_t)data[e->r] * (int8_t)data[e->d], 1)
op_fmulsu:
  MUL_FORM((uint8_t)data[e->r] * (int8_t)data[e->d], 1)
op_cpi:
  SUB_FORM(e->x, false, false)
op_sbci:
  SUB_FORM(e->x, true, true)
op_subi:
  SUB_FORM(e->x, false, true)
op_ori:
  LOGIC_FORM(|, e->x)
op_andi:
  LOGIC_FORM(&, e->x)
op_ldi:
  data[e->d] = e->x;
  NEXT(1, 2);
op_ldd: {
  uint8_t v;
  LOAD(v, POINTER(e->x) + e->r);
  data[e->d] = v;
  NEXT(2, 2);
}
op_std:
  STORE(POINTER(e->x) + e->r, data[e->d]);
  NEXT(2, 2);
op_ld_inc: {
  const uint8_t reg = e->x, d = e->d;
  const uint16_t p = POINTER(reg);
  uint8_t v;
  LOAD(v, p);
  data[reg + 1] = (uint8_t)((p + 1) >> 8);
  data[reg] = (uint8_t)(p + 1);
  data[d] = v;
  NEXT(2, 2);
}
op_ld_dec: {
  const uint8_t reg = e->x, d = e->d;
  const uint16_t p = (uint16_t)(POINTER(reg) - 1);
  uint8_t v;
  LOAD(v, p);
  data[reg + 1] = (uint8_t)(p >> 8);
  data[reg] = (uint8_t)p;
  data[d] = v;
  NEXT(2, 2);
}
op_st_inc: {
  const uint8_t reg = e->x, v = data[e->d];
  const uint16_t p = POINTER(reg);
  STORE(p, v);
  data[reg + 1] = (uint8_t)((p + 1) >> 8);
  data[reg] = (uint8_t)(p + 1);
  NEXT(2, 2);
}
op_st_dec: {
  const uint8_t reg = e->x, v = data[e->d];
  const uint16_t p = (uint16_t)(POINTER(reg) - 1);
  STORE(p, v);
  data[reg + 1] = (uint8_t)(p >> 8);
  data[reg] = (uint8_t)p;
  NEXT(2, 2);
}
op_lds: {
  const uint8_t d = e->d;
  uint8_t v;
  LOAD(v, flash_word(flash, pc + 2));
  data[d] = v;
  NEXT(2, 4);
}
op_sts: {
  const uint8_t v = data[e->d];
  STORE(flash_word(flash, pc + 2), v);
  NEXT(2, 4);
}
op_lpm_r0:
  data[0] = flash[POINTER(R_ZL)];
  NEXT(3, 2);
op_lpm:
  data[e->d] = flash[POINTER(R_ZL)];
  NEXT(3, 2);
op_lpm_inc: {
  const uint16_t z = POINTER(R_ZL);
  data[e->d] = flash[z];
  data[R_ZH] = (uint8_t)((z + 1) >> 8);
  data[R_ZL] = (uint8_t)(z + 1);
  NEXT(3, 2);
}
  /* ELPM on a part without RAMPZ: simavr logs an invalid opcode and reads data[0] as RAMPZ. */
op_elpm_r0:
  if (!avr->rampz) {
    SYNC();
    invalid_opcode(avr, pc);
    RESYNC();
  }
  data[0] = flash[data[R_ZL] | (data[R_ZH] << 8) | (data[avr->rampz] << 16)];
  NEXT(3, 2);
op_elpm: {
  if (!avr->rampz) {
    SYNC();
    invalid_opcode(avr, pc);
    RESYNC();
  }
  uint32_t z = (uint32_t)(data[R_ZL] | (data[R_ZH] << 8) | (data[avr->rampz] << 16));
  data[e->d] = flash[z];
  if (e->op == OP_ELPM_INC) {
    z++;
    STORE(avr->rampz, z >> 16);
    data[R_ZH] = (uint8_t)(z >> 8);
    data[R_ZL] = (uint8_t)z;
  }
  NEXT(3, 2);
}
op_push: {
  const uint8_t v = data[e->d];
  const uint16_t sp = SP();
  STORE(sp, v);
  SET_SP(sp - 1);
  NEXT(2, 2);
}
op_pop: {
  const uint8_t d = e->d;
  const uint16_t sp = (uint16_t)(SP() + 1);
  uint8_t v;
  LOAD(v, sp);
  SET_SP(sp);
  data[d] = v;
  NEXT(2, 2);
}
op_com: {
  const uint8_t res = (uint8_t)(0xff - data[e->d]);
  data[e->d] = res;
  fc_sreg_merge(s, FC_CZNVS, fc_flags.logic[res] | 1u); /* C = 1 */
  NEXT(1, 2);
}
op_neg: {
  const uint8_t vd = data[e->d];
  const uint8_t res = (uint8_t)(0 - vd);
  data[e->d] = res;
  s[S_H] = ((res >> 3) | (vd >> 3)) & 1;
  s[S_C] = res != 0;
  fc_sreg_merge(s, FC_ZNVS, fc_flags.inc[res]); /* V: res is 0x80, as after INC */
  NEXT(1, 2);
}
op_swap: {
  const uint8_t vd = data[e->d];
  data[e->d] = (uint8_t)((vd >> 4) | (vd << 4));
  NEXT(1, 2);
}
op_inc: {
  const uint8_t res = (uint8_t)(data[e->d] + 1);
  data[e->d] = res;
  fc_sreg_merge(s, FC_ZNVS, fc_flags.inc[res]);
  NEXT(1, 2);
}
op_dec: {
  const uint8_t res = (uint8_t)(data[e->d] - 1);
  data[e->d] = res;
  fc_sreg_merge(s, FC_ZNVS, fc_flags.dec[res]);
  NEXT(1, 2);
}
op_asr: {
  const uint8_t vd = data[e->d];
  const uint8_t res = (uint8_t)((vd >> 1) | (vd & 0x80));
  data[e->d] = res;
  fc_sreg_merge(s, FC_CZNVS, fc_flags.shift[(vd & 1u) << 8 | res]);
  NEXT(1, 2);
}
op_lsr: {
  const uint8_t vd = data[e->d];
  const uint8_t res = vd >> 1;
  data[e->d] = res;
  fc_sreg_merge(s, FC_CZNVS, fc_flags.shift[(vd & 1u) << 8 | res]); /* N = 0 */
  NEXT(1, 2);
}
op_ror: {
  const uint8_t vd = data[e->d];
  const uint8_t res = (uint8_t)((s[S_C] ? 0x80 : 0) | vd >> 1);
  data[e->d] = res;
  fc_sreg_merge(s, FC_CZNVS, fc_flags.shift[(vd & 1u) << 8 | res]);
  NEXT(1, 2);
}
op_adiw: {
  const uint8_t p = e->d;
  const uint16_t vp = POINTER(p);
  const uint16_t res = (uint16_t)(vp + e->x);
  data[p + 1] = (uint8_t)(res >> 8);
  data[p] = (uint8_t)res;
  flags_word(s, res, ((~vp & res) >> 15) & 1, ((~res & vp) >> 15) & 1);
  NEXT(2, 2);
}
op_sbiw: {
  const uint8_t p = e->d;
  const uint16_t vp = POINTER(p);
  const uint16_t res = (uint16_t)(vp - e->x);
  data[p + 1] = (uint8_t)(res >> 8);
  data[p] = (uint8_t)res;
  flags_word(s, res, ((vp & ~res) >> 15) & 1, ((res & ~vp) >> 15) & 1);
  NEXT(2, 2);
}
op_bset:
  if (e->r == S_I) {
    STOP(); /* the interrupt state may change */
  }
  sreg_set(avr, e->r, 1);
  NEXT(1, 2);
op_bclr:
  if (e->r == S_I) {
    STOP();
  }
  sreg_set(avr, e->r, 0);
  NEXT(1, 2);
op_bld: {
  const uint8_t vd = data[e->d];
  data[e->d] = (uint8_t)((vd & ~e->x) | (s[S_T] ? e->x : 0));
  NEXT(1, 2);
}
op_bst:
  s[S_T] = (data[e->d] >> e->r) & 1;
  NEXT(1, 2);
op_in: {
  const uint8_t d = e->d;
  uint8_t v;
  LOAD(v, e->x);
  data[d] = v;
  NEXT(1, 2);
}
op_out:
  STORE(e->x, data[e->d]);
  NEXT(1, 2);
op_cbi: {
  const uint8_t a = e->d, mask = e->x;
  uint8_t v;
  LOAD(v, a);
  STORE(a, v & (uint8_t)~mask);
  NEXT(2, 2);
}
op_sbi: {
  const uint8_t a = e->d, mask = e->x;
  uint8_t v;
  LOAD(v, a);
  STORE(a, v | mask);
  NEXT(2, 2);
}
op_sbic: {
  const uint8_t mask = e->x;
  uint8_t v;
  LOAD(v, e->d);
  if (!(v & mask)) {
    goto skip;
  }
  NEXT(1, 2);
}
op_sbis: {
  const uint8_t mask = e->x;
  uint8_t v;
  LOAD(v, e->d);
  if (v & mask) {
    goto skip;
  }
  NEXT(1, 2);
}
op_sbrc:
  if (!(data[e->d] & e->x)) {
    goto skip;
  }
  NEXT(1, 2);
op_sbrs:
  if (data[e->d] & e->x) {
    goto skip;
  }
  NEXT(1, 2);
op_brbs:
  if (s[e->r]) {
    NEXT(2, (uint32_t)(int32_t)(int16_t)e->k);
  }
  NEXT(1, 2);
op_brbc:
  if (!s[e->r]) {
    NEXT(2, (uint32_t)(int32_t)(int16_t)e->k);
  }
  NEXT(1, 2);
op_rjmp:
  pc = e->k;
  NEXT(2, 0);
op_rcall:
  PUSH_PC(pc + 2);
  pc = e->k;
  NEXT(3, 0);
op_jmp:
  NEXT_FAR(3, (((uint32_t)((e->word & 0x01f0) >> 3 | (e->word & 1)) << 16) | flash_word(flash, pc + 2)) << 1);
op_call: {
  const uint32_t target = (((uint32_t)((e->word & 0x01f0) >> 3 | (e->word & 1)) << 16) | flash_word(flash, pc + 2))
                          << 1;
  PUSH_PC(pc + 4);
  NEXT_FAR(4, target);
}
op_ijmp:
  NEXT_FAR(2, (uint32_t)POINTER(R_ZL) << 1);
op_icall: {
  const uint32_t target = (uint32_t)POINTER(R_ZL) << 1;
  PUSH_PC(pc + 2);
  NEXT_FAR(3, target);
}
op_eijmp: { /* EIJMP and EICALL */
  if (!avr->eind) {
    SYNC();
    invalid_opcode(avr, pc);
    RESYNC();
  }
  const uint32_t target = ((uint32_t)POINTER(R_ZL) | ((uint32_t)data[avr->eind] << 16)) << 1;
  if (e->op == OP_EICALL) {
    PUSH_PC(pc + 2);
    NEXT_FAR(3, target);
  }
  NEXT_FAR(2, target);
}
op_reti: {
  SYNC();
  sreg_set(avr, S_I, 1);
  interrupt_return(avr);
  RESYNC();
  uint32_t target;
  POP_PC(target);
  NEXT_FAR(4, target);
}
op_ret: {
  uint32_t target;
  POP_PC(target);
  NEXT_FAR(4, target);
}
op_sleep:
  SYNC();
  if (!avr_has_pending_interrupts(avr) || !s[S_I]) {
    avr->state = cpu_Sleeping;
  }
  RESYNC();
  NEXT(1, 2);
op_break:
  if (avr->gdb) { /* not reached: a core with gdb runs simavr's interpreter */
    STOP();
    avr->state = cpu_StepDone;
    NEXT(0, 0);
  }
  NEXT(1, 2);
op_wdr:
  SYNC();
  avr_ioctl(avr, AVR_IOCTL_WATCHDOG_RESET, 0);
  RESYNC();
  NEXT(1, 2);
op_spm:
  SYNC();
  avr_ioctl(avr, AVR_IOCTL_FLASH_SPM, 0);
  RESYNC();
  NEXT(1, 2);

skip: /* CPSE, SBRC, SBRS, SBIC, SBIS: the next instruction, of one word or two, is skipped */
  if (next_is_two_words(flash, pc + 2)) {
    NEXT(3, 6);
  }
  NEXT(2, 4);

check: /* the batch's end, something outside the core ran (limit 0), or the PC may be off the flash */
  if (limit == 0 && avr->state == cpu_Running && avr->interrupt_state == 0 && cycle < end) {
    limit = end;
    goto go_on;
  }
  /* The instructions after SEI, RETI or an SREG write that sets I: simavr's step would end the
   * batch here, find no cycle timer due, count the interrupt delay down (its
   * avr_service_interrupts) and bound a new batch by the first timer and `until`. Done here
   * when that is all the step would do. */
  if (until && avr->state == cpu_Running && avr->interrupt_state < 0 && s[S_I] && cycle < until) {
    const avr_cycle_timer_slot_p first = avr->cycle_timers.timer;
    const avr_cycle_count_t timer = first ? first->when : UINT64_MAX;
    if (timer > cycle) {
      if (++avr->interrupt_state == 0) {
        avr->interrupt_state = !avr_int_pending_isempty(&avr->interrupts.pending);
      }
      end = timer < until ? timer : until;
      limit = avr->interrupt_state == 0 ? end : 0;
      goto go_on;
    }
  }
  avr->pc = (uint32_t)(e - code) * 2; /* the last instruction's address */
  avr->cycle = cycle;
  avr->run_cycle_count = end - (cycle - cycles); /* not lowered by the last instruction, as simavr */
  return pc;
go_on:
  if (__builtin_expect(pc >= flashend, 0)) {
    goto off_the_flash;
  }
  DISPATCH();
off_the_flash:
  SYNC();
  avr_sadly_crashed(avr, 0); /* as simavr's core: no instruction there */
  return 0;
#undef STOP
#undef SYNC
#undef RESYNC
#undef DISPATCH
#undef NEXT
#undef NEXT_FAR
#undef STORE
#undef LOAD
#undef SP
#undef SET_SP
#undef PUSH_PC
#undef POP_PC
#undef ADD_FORM
#undef SUB_FORM
#undef LOGIC_FORM
#undef POINTER
#undef MUL_FORM
}

/* ---- lifecycle ---- */

bool fast_core_wanted(void) {
  const char *choice = getenv("AX12_SIM_CORE");
  return !choice || strcmp(choice, "simavr") != 0;
}

fast_core_t *fast_core_new(const avr_t *avr) {
  if (avr->flashend >= 0x10000u || avr->address_size != 2) {
    return NULL;
  }
  fast_core_t *core = calloc(1, sizeof(*core));
  if (!core) {
    return NULL;
  }
  core->words = (avr->flashend + 1) / 2;
  core->code = calloc(core->words, sizeof(*core->code));
  if (!core->code) {
    free(core);
    return NULL;
  }
  fc_flags_init();
  fc_handlers_t handlers;
  (void)run(NULL, NULL, 0, &handlers);
  for (uint32_t i = 0; i < core->words; i++) {
    decode(avr, &core->code[i], i * 2, flash_word(avr->flash, i * 2), handlers);
  }
  return core;
}

uint32_t fast_core_run(fast_core_t *core, avr_t *avr, uint64_t until) { return run(core, avr, until, NULL); }

void fast_core_free(fast_core_t *core) {
  if (core) {
    free(core->code);
    free(core);
  }
}
