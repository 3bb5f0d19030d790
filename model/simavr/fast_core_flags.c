/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "fast_core_flags.h"

#include <pthread.h>

fc_flag_tables_t fc_flags;

static pthread_once_t filled = PTHREAD_ONCE_INIT;

/* An 8-byte SREG word from the flags' values (index i: simavr's flag i). */
static uint64_t word_of(const uint8_t flags[8]) {
  uint64_t w;
  memcpy(&w, flags, sizeof(w));
  return w;
}

static uint64_t znvs(uint8_t res, uint8_t v) {
  const uint8_t n = res >> 7;
  const uint8_t f[8] = {[1] = res == 0, [2] = n, [3] = v, [4] = (uint8_t)(n ^ v)};
  return word_of(f);
}

static void fill(void) {
  for (unsigned i = 0; i < 256; i++) {
    const uint8_t n = (i & FC_IX_N) != 0, v = (i & FC_IX_V) != 0;
    const uint8_t arith[8] = {[0] = (i & FC_IX_C) != 0, [1] = (i & FC_IX_Z) != 0, [2] = n, [3] = v,
                              [4] = (uint8_t)(n ^ v), [5] = (i & FC_IX_H) != 0};
    fc_flags.arith[i] = word_of(arith);
    const uint8_t res = (uint8_t)i;
    fc_flags.logic[i] = znvs(res, 0);
    fc_flags.inc[i] = znvs(res, res == 0x80);
    fc_flags.dec[i] = znvs(res, res == 0x7f);
    for (unsigned c = 0; c < 2; c++) {
      const uint8_t rn = res >> 7;
      const uint8_t shift[8] = {[0] = (uint8_t)c, [1] = res == 0, [2] = rn, [3] = (uint8_t)(rn ^ c), [4] = (uint8_t)c};
      fc_flags.shift[c << 8 | i] = word_of(shift);
    }
    uint8_t all[8];
    for (unsigned b = 0; b < 8; b++) {
      all[b] = (i >> b) & 1u;
    }
    fc_flags.sreg[i] = word_of(all);
  }
}

void fc_flags_init(void) { (void)pthread_once(&filled, fill); }
