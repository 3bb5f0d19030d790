/* xorshift32 for the tests' random streams: a fixed seed gives the same stream on every run
 * and host. The state must not be 0. */
#ifndef XORSHIFT32_H
#define XORSHIFT32_H

#include <stdint.h>

static inline uint32_t xorshift32_next(uint32_t *state) {
  uint32_t x = *state;
  x ^= x << 13;
  x ^= x >> 17;
  x ^= x << 5;
  *state = x;
  return x;
}

#endif
