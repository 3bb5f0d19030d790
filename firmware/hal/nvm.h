/* The persistent settings in EEPROM (docs/hardware.md "EEPROM image", core dxl_image.h: two
 * slots written in turn).
 *
 * Write policy: nvm_persist() builds a slot of the EEPROM area for the slot that does not
 * hold the settings in use, with the next sequence number; nvm_service(), called from the
 * main loop, then writes one byte whenever the EEPROM is ready, in dxl_image_write_offset()
 * order (the sequence number last), only the bytes whose EEPROM value differs (as
 * eeprom_update_byte would). Once its last byte is written that slot holds the settings in
 * use. A new nvm_persist() while writing rebuilds the same slot with the newer settings and
 * restarts its scan, so the other slot keeps the last complete settings throughout. Nothing
 * blocks: a byte takes 3.4 ms on silicon, the main loop runs on meanwhile and EE_READY wakes
 * it. Bound: settings survive a power cut at most (DXL_IMAGE_SLOT_BYTES x 3.4 ms = 92 ms)
 * after the last nvm_persist(); typically (changed bytes + 3) x 3.4 ms.
 * Main loop only (the EE_READY ISR only clears EERIE: a wake-up).
 */
#ifndef HAL_NVM_H
#define HAL_NVM_H

#include <stdbool.h>
#include <stdint.h>

/* Reads both slots. Returns the EEPROM area of the newest valid one (CT_EEPROM_SIZE bytes,
 * valid until the next nvm_persist), NULL when neither is valid. */
const uint8_t *nvm_load(void);

/* Starts persisting eeprom_area (CT_EEPROM_SIZE bytes; copied at once). */
void nvm_persist(const uint8_t *eeprom_area);

/* True when nvm_service() has a byte to look at now (the sleep test). */
bool nvm_work_ready(void);

/* True while a store is under way: bytes left to compare, or the last one still being written. */
bool nvm_busy(void);

/* Writes the next differing byte if the EEPROM is ready. */
void nvm_service(void);

#endif
