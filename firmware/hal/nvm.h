/* The EEPROM image at address 0 (docs/hardware.md "EEPROM image", core dxl_image.h).
 *
 * Write policy: nvm_persist() builds the image of an EEPROM area; nvm_service(), called from
 * the main loop, then writes one byte whenever the EEPROM is ready, in offset order, only the
 * bytes whose EEPROM value differs (as eeprom_update_byte would), so the CRC byte (last
 * offset) is written after every data byte it covers. A new nvm_persist() while writing
 * restarts the scan with the new image. Nothing blocks: a byte takes 3.4 ms on silicon, the
 * main loop sleeps meanwhile and EE_READY wakes it. Power lost between a data byte and the
 * CRC leaves an image that fails its CRC: the next boot falls back to factory defaults.
 * Main loop only (the EE_READY ISR only clears EERIE: a wake-up).
 */
#ifndef HAL_NVM_H
#define HAL_NVM_H

#include <stdbool.h>
#include <stdint.h>

/* Reads the image. Returns its EEPROM area (CT_EEPROM_SIZE bytes, valid until the next
 * nvm_persist) when the image is valid, NULL when it is blank or corrupt. */
const uint8_t *nvm_load(void);

/* Starts persisting eeprom_area (CT_EEPROM_SIZE bytes; copied at once). */
void nvm_persist(const uint8_t *eeprom_area);

/* True until every byte of the last image is in the EEPROM and the last write finished. */
bool nvm_busy(void);

/* True when nvm_service() has a byte to look at now (the sleep test). */
bool nvm_work_ready(void);

/* Writes the next differing byte if the EEPROM is ready. */
void nvm_service(void);

#endif
