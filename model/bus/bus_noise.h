/* SPDX-License-Identifier: MIT */
/* Noise on the wire: every bit of a byte's frame (start, 8 data LSB first, stop) is flipped
 * independently with probability bit_error_rate. Pure C, deterministic: a seeded PRNG
 * (splitmix64, written here), one frame drawn per call, so the same seed and the same
 * sequence of frames give the same flips.
 *
 * Cost per frame: one PRNG draw compared with P(some bit flips) = 1 - (1 - p)^10; only a
 * frame that is hit draws more (which bit flips first, then each later bit with p). The
 * result has exactly the distribution of ten independent draws. */
#ifndef SIM_BUS_NOISE_H
#define SIM_BUS_NOISE_H

#include <stdbool.h>
#include <stdint.h>

#define BUS_NOISE_FRAME_BITS 10u /* 8N1: start, 8 data, stop */
#define BUS_NOISE_DEFAULT_SEED 1u

/* Bits of a flip mask (bus_noise_next_frame): bit i = frame bit i on the wire. */
#define BUS_NOISE_START_BIT 0x001u
#define BUS_NOISE_DATA_BITS 0x1FEu /* data bit k (value bit k) = frame bit k + 1 */
#define BUS_NOISE_STOP_BIT 0x200u

typedef struct {
  double bit_error_rate; /* per bit, [0, 1); 0 = no noise, no PRNG draws */
  /* first_flip_cdf[i] = P(the first flipped bit is at or before frame bit i)
   * = 1 - (1 - p)^(i + 1); the last entry is P(the frame is hit at all). */
  double first_flip_cdf[BUS_NOISE_FRAME_BITS];
  uint64_t prng_state;
} bus_noise_t;

/* True for a usable rate: a number in [0, 1). */
bool bus_noise_rate_valid(double bit_error_rate);

/* Sets the rate and seeds the PRNG. Returns false (and leaves noise off) for an invalid rate. */
bool bus_noise_init(bus_noise_t *noise, double bit_error_rate, uint64_t seed);

/* The flips of the next frame on the wire: a mask of BUS_NOISE_* bits, 0 when the frame
 * arrives intact (always 0 at rate 0). */
uint16_t bus_noise_next_frame(bus_noise_t *noise);

/* What the flips in mask do to the byte's value (XOR it in). */
static inline uint8_t bus_noise_data_xor(uint16_t mask) { return (uint8_t)((mask & BUS_NOISE_DATA_BITS) >> 1); }

/* True when mask flips the start or the stop bit: a framing error. */
static inline bool bus_noise_framing_error(uint16_t mask) {
  return (mask & (BUS_NOISE_START_BIT | BUS_NOISE_STOP_BIT)) != 0u;
}

#endif
