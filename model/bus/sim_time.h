/* SPDX-License-Identifier: MIT */
/* Simulated time: one clock for the whole world, counted in CPU cycles of the 16 MHz parts
 * (docs/hardware.md). Every AVR runs at this frequency, so an avr_t's cycle counter and the
 * world's clock are the same number. */
#ifndef SIM_TIME_H
#define SIM_TIME_H

#include <stdint.h>

#define SIM_CPU_HZ 16000000u
#define SIM_CYCLES_PER_US 16u

typedef uint64_t sim_cycles_t;

#define SIM_CYCLES_NEVER UINT64_MAX

static inline sim_cycles_t sim_us(uint64_t us) { return us * SIM_CYCLES_PER_US; }
static inline sim_cycles_t sim_ms(uint64_t ms) { return ms * 1000u * SIM_CYCLES_PER_US; }
static inline double sim_cycles_to_us(sim_cycles_t cycles) { return (double)cycles / SIM_CYCLES_PER_US; }

/* Dynamixel baud: 2 000 000 / (value + 1) bit/s; with U2X at 16 MHz a bit is 8 (value + 1)
 * cycles (docs/hardware.md "UART"). */
static inline double sim_baud_reg_to_bps(unsigned value) { return 2000000.0 / (double)(value + 1u); }
static inline double sim_bps_to_cycles_per_bit(double bps) { return (double)SIM_CPU_HZ / bps; }

#endif
