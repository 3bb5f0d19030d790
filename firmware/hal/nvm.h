/* The persistent settings in EEPROM (docs/hardware.md "EEPROM image", core dxl_image.h: two
 * slots written in turn).
 *
 * Write policy: nvm_persist() marks the settings changed. nvm_service(), called from the main
 * loop, then builds a slot of the EEPROM area for the slot that does not hold the settings in
 * use, with the next sequence number, and writes one byte whenever the EEPROM is ready, in
 * dxl_image_write_offset() order (the sequence number last), only the bytes whose EEPROM
 * value differs (as eeprom_update_byte would). Once its last byte is written that slot holds
 * the settings in use. A store is never restarted: settings changed while one is under way
 * are stored by the next one (to the other slot), which starts when this one has its
 * sequence number and takes the settings as they are then. So a stream of writes cannot
 * starve the store, and the slot not being written always holds complete settings. Nothing
 * blocks: a byte takes 3.4 ms on silicon, the main loop runs on meanwhile and EE_READY wakes
 * it. Bound: a change is stored by the end of the store after the one under way; a store
 * writes the bytes that differ from the slot it overwrites, 3.4 ms each: 4 (sequence number
 * and CRC included) when one byte of the settings changed, so a stream of writes of one
 * one-byte item is stored within 27 ms of each (docs/firmware.md "EEPROM write policy").
 * Main loop only (the EE_READY ISR only clears EERIE: a wake-up).
 */
#ifndef HAL_NVM_H
#define HAL_NVM_H

#include <avr/io.h>
#include <stdbool.h>
#include <stdint.h>

/* Settings changed and not yet in a store: GPIOR0 bit NVM_PENDING_BIT (one SBI, CBI, SBIS;
 * main loop only, beside board.h's wake flag). */
#define NVM_PENDING_BIT 1

/* Reads both slots. Returns the EEPROM area of the newest valid one (CT_EEPROM_SIZE bytes,
 * valid until the next store starts), NULL when neither is valid. */
const uint8_t *nvm_load(void);

/* The settings (the control table's EEPROM area) changed: nvm_service() stores them. */
static inline void nvm_persist(void) { GPIOR0 |= _BV(NVM_PENDING_BIT); }

static inline bool nvm_persist_pending(void) { return (GPIOR0 & _BV(NVM_PENDING_BIT)) != 0; }

/* True when nvm_service() has a byte to look at now (the sleep test). */
bool nvm_work_ready(void);

/* True while settings wait for their store or a store is under way: bytes left to compare, or
 * the last one still being written. */
bool nvm_busy(void);

/* Starts a store of eeprom_area (CT_EEPROM_SIZE bytes, copied) when the settings changed and
 * no store is under way, and writes its next differing byte if the EEPROM is ready. */
void nvm_service(const uint8_t *eeprom_area);

#endif
