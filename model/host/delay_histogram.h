/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A histogram of delays in microseconds, for their quantiles (p50, p99) and maximum without
 * keeping every sample: exact to 1 us below 1024 us, within 1/64 (1.6 %) above, up to
 * 2^31 us (about 36 minutes; longer delays count as that). Fixed size, no allocation, no
 * locking (one thread writes and reads it). */
#ifndef SIM_DELAY_HISTOGRAM_H
#define SIM_DELAY_HISTOGRAM_H

#include <stdint.h>

#define DELAY_HISTOGRAM_LINEAR_US 1024u /* below: one bucket per microsecond */
#define DELAY_HISTOGRAM_SUB_BUCKETS 64u /* per doubling above */
#define DELAY_HISTOGRAM_DOUBLINGS 21u   /* 2^10 .. 2^31 us */
#define DELAY_HISTOGRAM_BUCKETS (DELAY_HISTOGRAM_LINEAR_US + DELAY_HISTOGRAM_DOUBLINGS * DELAY_HISTOGRAM_SUB_BUCKETS)

typedef struct {
  uint64_t count;
  double max_us;
  uint32_t buckets[DELAY_HISTOGRAM_BUCKETS];
} delay_histogram_t;

void delay_histogram_clear(delay_histogram_t *h);

/* Records one delay; a negative one (or NaN) counts as 0. */
void delay_histogram_add(delay_histogram_t *h, double delay_us);

/* The smallest recorded value v such that a fraction q (0..1) of the samples are <= v, as the
 * upper edge of its bucket (never above the maximum); 0 without samples. */
double delay_histogram_quantile_us(const delay_histogram_t *h, double q);

#endif
