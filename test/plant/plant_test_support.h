/* Helpers shared by the plant tests: named after the steps of a bench test. */
#ifndef AX12_PLANT_TEST_SUPPORT_H
#define AX12_PLANT_TEST_SUPPORT_H

#include <math.h>

#include "plant.h"

#define KGF_CM_NM 0.0980665
#define PI 3.141592653589793
#define DEG_RAD (PI / 180.0)

/* Assert |actual - expected| <= tol (cmocka has no float assert in 1.1). */
#define assert_near(actual, expected, tol)                                                   \
    do {                                                                                     \
        const double a_ = (actual);                                                          \
        const double e_ = (expected);                                                        \
        if (!(fabs(a_ - e_) <= (tol))) {                                                     \
            fail_msg("%s = %.6g, expected %.6g +- %.3g", #actual, a_, e_, (double)(tol));    \
        }                                                                                    \
    } while (0)

#define assert_within_pct(actual, expected, pct) \
    assert_near((actual), (expected), fabs(expected) * (pct) / 100.0)

#define assert_true_msg(cond, ...)  \
    do {                            \
        if (!(cond)) {              \
            fail_msg(__VA_ARGS__);  \
        }                           \
    } while (0)

/* A servo at rest at 150 deg on a supply of source_v behind source_r_ohm, 25 degC. */
static inline ax12_plant_t given_servo(double source_v, double source_r_ohm)
{
    ax12_plant_t plant;
    ax12_plant_init_on_supply(&plant, source_v, source_r_ohm);
    return plant;
}

static inline void given_load(ax12_plant_t *plant, ax12_load_t load)
{
    ax12_plant_set_load(plant, &load);
}

/* Hold duty for seconds in steps of dt_s. */
static inline void run_for(ax12_plant_t *plant, double duty, double seconds, double dt_s)
{
    const long n = (long)(seconds / dt_s + 0.5);
    for (long i = 0; i < n; i++) {
        ax12_plant_step(plant, duty, dt_s);
    }
}

/* The ADC's view of a pin voltage (AVCC = 5000 mV, 10 bits). */
static inline int adc_code(double mv)
{
    const int code = (int)(mv * 1024.0 / 5000.0);
    return code > 1023 ? 1023 : (code < 0 ? 0 : code);
}

#endif
