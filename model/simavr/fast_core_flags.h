/* SPDX-License-Identifier: GPL-3.0-or-later */
/* SREG's flags as the fast core (fast_core.c) computes them. simavr 1.6 keeps SREG as eight
 * bytes, avr->sreg[S_C .. S_I], each 0 or 1; an instruction that sets flags here writes them
 * as one 8-byte word: the bytes it does not set kept, the others from a table of 8-byte words
 * indexed by what decides them. The values are simavr's (_avr_flags_add_zns and the others in
 * its sim_core.c), checked against simavr's interpreter by tests/sim test_fast_core.
 *
 * Additions and subtractions (ADD, ADC, SUB, SBC, CP, CPC, CPI, SUBI, SBCI) take their flags
 * from the host's: on x86-64 the same 8-bit add or subtract (with the carry for ADC, SBC,
 * CPC, SBCI) leaves AVR's C, Z, N, V and H in the host's CF, ZF, SF, OF and AF (LAHF and
 * SETO read them); elsewhere (or with FAST_CORE_PORTABLE_FLAGS) they are computed in C, to
 * the same table index. */
#ifndef SIM_FAST_CORE_FLAGS_H
#define SIM_FAST_CORE_FLAGS_H

#include <stdint.h>
#include <string.h>

#if defined(__x86_64__) && !defined(FAST_CORE_PORTABLE_FLAGS)
#define FAST_CORE_HOST_FLAGS 1
#else
#define FAST_CORE_HOST_FLAGS 0
#endif

/* The bytes of the 8-byte word avr->sreg, by flag (S_C = 0 ... S_I = 7 in simavr). */
#define FC_BYTE(flag) ((uint64_t)0xff << (8 * (flag)))
#define FC_C FC_BYTE(0)
#define FC_Z FC_BYTE(1)
#define FC_N FC_BYTE(2)
#define FC_V FC_BYTE(3)
#define FC_S FC_BYTE(4)
#define FC_H FC_BYTE(5)
#define FC_ARITH (FC_C | FC_Z | FC_N | FC_V | FC_S | FC_H) /* add, subtract */
#define FC_ZNVS (FC_Z | FC_N | FC_V | FC_S)                  /* logic, INC, DEC */
#define FC_CZNVS (FC_C | FC_ZNVS)                            /* shifts right, COM */

/* An arithmetic index: the host's LAHF layout (bit 7 N, 6 Z, 4 H, 0 C) with V in bit 3. */
#define FC_IX_C 0x01u
#define FC_IX_V 0x08u
#define FC_IX_H 0x10u
#define FC_IX_Z 0x40u
#define FC_IX_N 0x80u

typedef struct {
  uint64_t arith[256];      /* by arithmetic index: C Z N V S H */
  uint64_t logic[256];      /* by result: Z N S, V = 0 */
  uint64_t inc[256];        /* by result: Z N V S of INC */
  uint64_t dec[256];        /* by result: Z N V S of DEC */
  uint64_t shift[512];      /* by (the operand's bit 0) << 8 | result: C Z N V S of LSR, ASR, ROR */
  uint64_t sreg[256];       /* by SREG's value: all eight bytes */
} fc_flag_tables_t;

extern fc_flag_tables_t fc_flags;

/* Fills fc_flags (once per process; safe from several threads). */
void fc_flags_init(void);

/* The flag bytes in `bytes` under `mask` replace those of SREG's mirror s. */
static inline void fc_sreg_merge(uint8_t *s, uint64_t mask, uint64_t bytes) {
  uint64_t m;
  memcpy(&m, s, sizeof(m));
  m = (m & ~mask) | bytes;
  memcpy(s, &m, sizeof(m));
}

/* After SBC, CPC, SBCI: as after a subtraction, but Z stays set only if it was. */
static inline void fc_sreg_merge_keep_zero(uint8_t *s, uint64_t bytes) {
  uint64_t m;
  memcpy(&m, s, sizeof(m));
  m = (m & ~FC_ARITH) | (bytes & (m | ~FC_Z));
  memcpy(s, &m, sizeof(m));
}

#if FAST_CORE_HOST_FLAGS

/* rd op rr (op: addb, subb), the arithmetic index from the host's flags. */
#define FC_HOST_ARITH(op, rd, rr, index)                                                                              \
  __extension__({                                                                                                      \
    uint32_t ax_ = (rd);                                                                                               \
    uint8_t of_;                                                                                                       \
    __asm__(op " %b[rr_], %%al\n\tlahf\n\tseto %[of_]" : "+a"(ax_), [of_] "=q"(of_) : [rr_] "q"(rr) : "cc");          \
    *(index) = ((ax_ >> 8) & 0xffu) | ((uint32_t)of_ << 3);                                                           \
    (uint8_t) ax_;                                                                                                     \
  })
/* The same with AVR's carry (0 or 1) in: adcb, sbbb. */
#define FC_HOST_ARITH_CARRY(op, rd, rr, carry, index)                                                                 \
  __extension__({                                                                                                      \
    uint32_t ax_ = (rd);                                                                                               \
    uint8_t of_;                                                                                                       \
    __asm__("btl $0, %k[c_]\n\t" op " %b[rr_], %%al\n\tlahf\n\tseto %[of_]"                                           \
            : "+a"(ax_), [of_] "=q"(of_)                                                                               \
            : [rr_] "q"(rr), [c_] "q"((uint32_t)(carry))                                                               \
            : "cc");                                                                                                   \
    *(index) = ((ax_ >> 8) & 0xffu) | ((uint32_t)of_ << 3);                                                           \
    (uint8_t) ax_;                                                                                                     \
  })

static inline uint8_t fc_add8(uint8_t rd, uint8_t rr, uint32_t carry, uint32_t *index) {
  return FC_HOST_ARITH_CARRY("adcb", rd, rr, carry, index);
}
static inline uint8_t fc_add8_nc(uint8_t rd, uint8_t rr, uint32_t *index) { return FC_HOST_ARITH("addb", rd, rr, index); }
static inline uint8_t fc_sub8(uint8_t rd, uint8_t rr, uint32_t carry, uint32_t *index) {
  return FC_HOST_ARITH_CARRY("sbbb", rd, rr, carry, index);
}
static inline uint8_t fc_sub8_nc(uint8_t rd, uint8_t rr, uint32_t *index) { return FC_HOST_ARITH("subb", rd, rr, index); }

#else

/* The arithmetic index of res = rd + rr + carry (sub: rd - rr - carry); wide is that sum or
 * difference in more than 8 bits (bit 8: the carry or borrow out of bit 7). */
static inline uint32_t fc_arith_index(uint8_t rd, uint8_t rr, uint32_t wide, int sub) {
  const uint8_t res = (uint8_t)wide;
  const uint32_t c = (wide >> 8) & 1u;
  const uint32_t h = ((uint32_t)(rd ^ rr ^ res) >> 4) & 1u; /* the carry or borrow into bit 4 */
  const uint32_t v = sub ? (uint32_t)(((rd ^ rr) & (rd ^ res)) >> 7) : (uint32_t)((~(rd ^ rr) & (rd ^ res)) >> 7);
  return (res & FC_IX_N) | (res == 0 ? FC_IX_Z : 0u) | (h ? FC_IX_H : 0u) | (v ? FC_IX_V : 0u) | c;
}

static inline uint8_t fc_add8(uint8_t rd, uint8_t rr, uint32_t carry, uint32_t *index) {
  const uint32_t wide = (uint32_t)rd + rr + (carry & 1u);
  *index = fc_arith_index(rd, rr, wide, 0);
  return (uint8_t)wide;
}
static inline uint8_t fc_add8_nc(uint8_t rd, uint8_t rr, uint32_t *index) { return fc_add8(rd, rr, 0, index); }
static inline uint8_t fc_sub8(uint8_t rd, uint8_t rr, uint32_t carry, uint32_t *index) {
  const uint32_t wide = (uint32_t)rd - rr - (carry & 1u);
  *index = fc_arith_index(rd, rr, wide, 1);
  return (uint8_t)wide;
}
static inline uint8_t fc_sub8_nc(uint8_t rd, uint8_t rr, uint32_t *index) { return fc_sub8(rd, rr, 0, index); }

#endif

#endif
