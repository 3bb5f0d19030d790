/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The delay histogram of the real-time figures (model/host/delay_histogram.c): quantiles exact
 * to the microsecond below 1024 us, within 1/64 above, the maximum exact, bad samples as 0. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "delay_histogram.h"

static void test_quantiles_of_whole_microseconds_are_exact(void **state) {
  (void)state;
  static delay_histogram_t h;
  delay_histogram_clear(&h);
  for (int v = 1; v <= 1000; v++) {
    delay_histogram_add(&h, (double)v);
  }
  assert_int_equal(h.count, 1000);
  assert_true(delay_histogram_quantile_us(&h, 0.5) == 500.0);
  assert_true(delay_histogram_quantile_us(&h, 0.99) == 990.0);
  assert_true(delay_histogram_quantile_us(&h, 1.0) == 1000.0);
  assert_true(delay_histogram_quantile_us(&h, 0.0) == 1.0);
  assert_true(h.max_us == 1000.0);
}

static void test_long_delays_within_a_64th(void **state) {
  (void)state;
  static delay_histogram_t h;
  delay_histogram_clear(&h);
  const double values[] = {1024.0, 1500.0, 28100.0, 57000.0, 1.5e6, 2e9};
  for (size_t i = 0; i < sizeof(values) / sizeof(values[0]); i++) {
    delay_histogram_clear(&h);
    for (int k = 0; k < 99; k++) {
      delay_histogram_add(&h, 10.0);
    }
    delay_histogram_add(&h, values[i]);
    const double p100 = delay_histogram_quantile_us(&h, 1.0);
    assert_true(p100 <= values[i]); /* never above the maximum */
    assert_true(p100 >= values[i] * (1.0 - 1.0 / 64.0) - 1.0);
    assert_true(delay_histogram_quantile_us(&h, 0.99) == 10.0);
    assert_true(h.max_us == values[i]);
  }
}

static void test_a_p99_sees_one_late_sample_in_a_hundred(void **state) {
  (void)state;
  static delay_histogram_t h;
  delay_histogram_clear(&h);
  for (int k = 0; k < 980; k++) {
    delay_histogram_add(&h, 40.0);
  }
  for (int k = 0; k < 20; k++) {
    delay_histogram_add(&h, 28000.0);
  }
  assert_true(delay_histogram_quantile_us(&h, 0.5) == 40.0);
  const double p99 = delay_histogram_quantile_us(&h, 0.99);
  assert_true(p99 > 27000.0 && p99 <= 28000.0);
}

static void test_negative_and_nan_count_as_zero_and_empty_is_zero(void **state) {
  (void)state;
  static delay_histogram_t h;
  delay_histogram_clear(&h);
  assert_true(delay_histogram_quantile_us(&h, 0.5) == 0.0);
  delay_histogram_add(&h, -5.0);
  delay_histogram_add(&h, 0.0 / 0.0);
  assert_int_equal(h.count, 2);
  assert_true(delay_histogram_quantile_us(&h, 1.0) == 0.0);
  assert_true(h.max_us == 0.0);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_quantiles_of_whole_microseconds_are_exact),
      cmocka_unit_test(test_long_delays_within_a_64th),
      cmocka_unit_test(test_a_p99_sees_one_late_sample_in_a_hundred),
      cmocka_unit_test(test_negative_and_nan_count_as_zero_and_empty_is_zero),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
