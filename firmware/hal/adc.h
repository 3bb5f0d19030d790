/* ADC (docs/hardware.md "ADC"): AVCC reference (5 V), prescaler 128 (125 kHz ADC clock),
 * one conversion = 13 ADC clocks = 104 us (the first after enabling: 25 = 200 us).
 * No ADC interrupt: the control tick reads the finished conversion and starts the next one
 * (adc_start / adc_result), so the ADC never costs the UART a cycle.
 * Main loop only. */
#ifndef HAL_ADC_H
#define HAL_ADC_H

#include <stdbool.h>
#include <stdint.h>

#define ADC_CH_POT 0u    /* PC0: pot wiper, 0..5000 mV over 300 degrees */
#define ADC_CH_SUPPLY 1u /* PC1: supply / 5 */
#define ADC_CH_TEMP 2u   /* PC2: 500 mV + 10 mV per degree C */

void adc_init(void);

/* One conversion, waiting for it (boot only: about 104 us, 200 us for the first). */
uint16_t adc_read_blocking(uint8_t channel);

void adc_start(uint8_t channel);
bool adc_busy(void);
/* The last finished conversion, 0..1023 (reading x 5000 mV / 1024 at the pin). */
uint16_t adc_result(void);

/* Present Voltage (address 42): supply volts x 10, rounded to nearest.
 * supply_mv = reading x 25000 / 1024, so the value is round(reading x 250 / 1024). */
uint8_t adc_supply_decivolts(uint16_t reading);

/* Present Temperature (address 43): degrees C, rounded to nearest, clamped to 0..255.
 * pin_mv = reading x 5000 / 1024 = 500 + 10 x C, so C = round(reading x 125 / 256) - 50. */
uint8_t adc_temperature_c(uint16_t reading);

#endif
