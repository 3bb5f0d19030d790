/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "delay_histogram.h"

#include <string.h>

void delay_histogram_clear(delay_histogram_t *h) { memset(h, 0, sizeof(*h)); }

/* Bucket of a whole number of microseconds: v itself below 1024; above, the doubling it falls
 * in and its 64th part. */
static uint32_t bucket_of(uint64_t v) {
  if (v < DELAY_HISTOGRAM_LINEAR_US) {
    return (uint32_t)v;
  }
  uint32_t doubling = 0; /* v in [1024 << doubling, 2048 << doubling) */
  while ((v >> (doubling + 11u)) != 0u && doubling + 1u < DELAY_HISTOGRAM_DOUBLINGS) {
    doubling++;
  }
  uint64_t sub = (v >> (doubling + 4u)) - DELAY_HISTOGRAM_SUB_BUCKETS; /* 1024 << d is 64 << (d + 4) */
  if (sub >= DELAY_HISTOGRAM_SUB_BUCKETS) {
    sub = DELAY_HISTOGRAM_SUB_BUCKETS - 1u; /* beyond the range: the last bucket */
  }
  return DELAY_HISTOGRAM_LINEAR_US + doubling * DELAY_HISTOGRAM_SUB_BUCKETS + (uint32_t)sub;
}

/* The largest whole microsecond value of bucket b. */
static double upper_edge_us(uint32_t b) {
  if (b < DELAY_HISTOGRAM_LINEAR_US) {
    return (double)b;
  }
  const uint32_t doubling = (b - DELAY_HISTOGRAM_LINEAR_US) / DELAY_HISTOGRAM_SUB_BUCKETS;
  const uint32_t sub = (b - DELAY_HISTOGRAM_LINEAR_US) % DELAY_HISTOGRAM_SUB_BUCKETS;
  return (double)(((uint64_t)(DELAY_HISTOGRAM_SUB_BUCKETS + sub + 1u) << (doubling + 4u)) - 1u);
}

void delay_histogram_add(delay_histogram_t *h, double delay_us) {
  if (!(delay_us > 0.0)) {
    delay_us = 0.0;
  }
  const double top = (double)(1ull << 31);
  const uint64_t v = delay_us < top ? (uint64_t)delay_us : (uint64_t)top;
  h->buckets[bucket_of(v)]++;
  h->count++;
  if (delay_us > h->max_us) {
    h->max_us = delay_us;
  }
}

double delay_histogram_quantile_us(const delay_histogram_t *h, double q) {
  if (!h->count) {
    return 0.0;
  }
  if (q < 0.0) {
    q = 0.0;
  }
  if (q > 1.0) {
    q = 1.0;
  }
  const double wanted = q * (double)h->count;
  uint64_t rank = (uint64_t)wanted; /* rounded up: the rank-th smallest sample */
  if ((double)rank < wanted) {
    rank++;
  }
  if (rank == 0u) {
    rank = 1u;
  }
  uint64_t seen = 0;
  for (uint32_t b = 0; b < DELAY_HISTOGRAM_BUCKETS; b++) {
    seen += h->buckets[b];
    if (seen >= rank) {
      const double edge = upper_edge_us(b);
      return edge < h->max_us ? edge : h->max_us;
    }
  }
  return h->max_us;
}
