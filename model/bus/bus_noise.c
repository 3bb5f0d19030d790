/* SPDX-License-Identifier: MIT */
#include "bus_noise.h"

#include <math.h>
#include <string.h>

/* splitmix64: a Weyl sequence (golden-ratio increment) through a 64-bit finalizer. Every
 * seed, 0 included, gives a full-period stream. */
static uint64_t prng_next_u64(uint64_t *state) {
  *state += UINT64_C(0x9E3779B97F4A7C15);
  uint64_t z = *state;
  z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
  z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
  return z ^ (z >> 31);
}

/* Uniform in [0, 1), 53 random bits. */
static double prng_next_unit(uint64_t *state) { return (double)(prng_next_u64(state) >> 11) * 0x1.0p-53; }

bool bus_noise_rate_valid(double bit_error_rate) { return bit_error_rate >= 0.0 && bit_error_rate < 1.0; }

bool bus_noise_init(bus_noise_t *noise, double bit_error_rate, uint64_t seed) {
  memset(noise, 0, sizeof(*noise));
  noise->prng_state = seed;
  if (!bus_noise_rate_valid(bit_error_rate)) {
    return false; /* NaN fails the comparisons too */
  }
  noise->bit_error_rate = bit_error_rate;
  /* 1 - (1 - p)^n as -expm1(n ln(1 - p)): exact also for tiny p. */
  const double log_intact_per_bit = log1p(-bit_error_rate);
  for (unsigned i = 0; i < BUS_NOISE_FRAME_BITS; i++) {
    noise->first_flip_cdf[i] = -expm1(log_intact_per_bit * (double)(i + 1u));
  }
  return true;
}

uint16_t bus_noise_next_frame(bus_noise_t *noise) {
  if (noise->bit_error_rate <= 0.0) {
    return 0u;
  }
  /* One draw decides whether the frame is hit and, if so, where the first flip is: given
   * u < cdf[last], u is uniform below it, so P(first = i) = cdf[i] - cdf[i - 1]
   * = (1 - p)^i p, as for independent bits. */
  const double u = prng_next_unit(&noise->prng_state);
  if (u >= noise->first_flip_cdf[BUS_NOISE_FRAME_BITS - 1u]) {
    return 0u;
  }
  unsigned first = 0;
  while (u >= noise->first_flip_cdf[first]) {
    first++;
  }
  uint16_t mask = (uint16_t)(1u << first);
  /* The bits after the first are independent of it. */
  for (unsigned bit = first + 1u; bit < BUS_NOISE_FRAME_BITS; bit++) {
    if (prng_next_unit(&noise->prng_state) < noise->bit_error_rate) {
      mask |= (uint16_t)(1u << bit);
    }
  }
  return mask;
}
