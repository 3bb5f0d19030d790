/* ADC. See adc.h. */
#include "adc.h"

#include <avr/io.h>

#define ADMUX_AVCC _BV(REFS0)
#define ADCSRA_ON (_BV(ADEN) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0)) /* clk/128 */

void adc_init(void) {
  DIDR0 = _BV(ADC0D) | _BV(ADC1D) | _BV(ADC2D); /* no digital input buffers on analog pins */
  ADMUX = ADMUX_AVCC;
  ADCSRA = ADCSRA_ON;
}

/* One copy for its three callers (smaller on the ATmega88). */
__attribute__((noinline)) void adc_start(uint8_t channel) {
  ADMUX = (uint8_t)(ADMUX_AVCC | channel);
  ADCSRA = (uint8_t)(ADCSRA_ON | _BV(ADSC));
}

bool adc_busy(void) { return (ADCSRA & _BV(ADSC)) != 0; }

uint16_t adc_result(void) { return ADC; }

uint16_t adc_read_blocking(uint8_t channel) {
  adc_start(channel);
  while (adc_busy()) {
  }
  return adc_result();
}

/* (reading x factor + round) >> 8: the >> 8 a byte move (a 32-bit shift is a loop a bit).
 * One copy for both conversions (smaller on the ATmega88). */
static __attribute__((noinline)) uint16_t scaled_q8(uint16_t reading, uint8_t factor, uint16_t round) {
  return (uint16_t)(((uint32_t)reading * factor + round) >> 8);
}

uint8_t adc_supply_decivolts(uint16_t reading) {
  return (uint8_t)(scaled_q8(reading, 250u, 512u) >> 2); /* >> 10 in all: <= 250 */
}

uint8_t adc_temperature_c(uint16_t reading) {
  const uint16_t half_up = scaled_q8(reading, 125u, 128u); /* 0..500 */
  if (half_up <= 50u) {
    return 0;
  }
  if (half_up >= UINT8_MAX + 50u) { /* the cap tested before the subtraction: smaller code */
    return UINT8_MAX;
  }
  return (uint8_t)(half_up - 50u);
}
