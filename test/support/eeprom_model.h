/* The firmware's EEPROM writer (firmware/hal/nvm.c, which is AVR-only) on a byte array, for
 * the host tests: the one model of it that test_image, the settings sweep and the fuzzer use.
 *
 * It keeps nvm.c's RAM state and does what nvm.c does, step for step:
 *   eeprom_model_boot()     nvm_load() after a reset: the RAM state cleared, then the newest
 *                           valid slot read (DXL_IMAGE_NO_SLOT: the first write goes to slot 0);
 *   eeprom_model_persist()  nvm_persist(): the settings changed (copied here; nvm.c reads the
 *                           control table when their store starts, which holds the same bytes:
 *                           every change of its EEPROM area is persisted in the main-loop pass
 *                           that makes it, before nvm_service());
 *   eeprom_model_service()  nvm_service() with the EEPROM ready: with no store under way and
 *                           settings changed, builds the slot not in use with the next sequence
 *                           number (a store under way is never restarted: changes wait for the
 *                           next); walks the steps in dxl_image_write_offset() order, skips the
 *                           bytes that already hold their value, writes the first that differs
 *                           and returns (the EEPROM is then busy until the byte is in: the next
 *                           call is the next ready).
 * A power cut in the middle of a byte's write is eeprom_model_service() with torn != NULL: the
 * byte it would write is left holding *torn, and the model must be booted again before use.
 * A cut between two writes is simply a boot without further service. Portable C11. */
#ifndef EEPROM_MODEL_H
#define EEPROM_MODEL_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_image.h"
#include "dxl_table.h"

typedef struct {
  uint8_t image[DXL_IMAGE_BYTES]; /* the EEPROM, from address 0 */
  /* nvm.c's static state, same names */
  uint8_t slot_bytes[DXL_IMAGE_SLOT_BYTES];
  uint8_t slot_index;
  uint8_t steps_left;
  uint8_t active_slot;
  uint8_t active_sequence;
  bool pending; /* nvm.c's NVM_PENDING_BIT of GPIOR0 */
  uint8_t pending_area[CT_EEPROM_SIZE];
} eeprom_model_t;

/* nvm_load() after a reset: returns the EEPROM area of the newest valid slot (CT_EEPROM_SIZE
 * bytes, inside the model, valid until the next persist) or NULL. */
const uint8_t *eeprom_model_boot(eeprom_model_t *model);

/* nvm_persist(): eeprom_area (CT_EEPROM_SIZE bytes, copied) is stored by the next store. */
void eeprom_model_persist(eeprom_model_t *model, const uint8_t *eeprom_area);

/* True while settings wait for their store or a store has steps left (nvm_busy() with the
 * EEPROM ready). */
bool eeprom_model_busy(const eeprom_model_t *model);

/* nvm_service() with the EEPROM ready: returns true when it wrote a byte (at most one), false
 * when it wrote none (the store under way ended without one, or there was nothing to store;
 * settings persisted during a store then wait for the next call, as in nvm.c). With torn != NULL the
 * byte's write is cut by a power loss: the byte holds *torn afterwards (any value, the old and
 * the new included) and true is returned. */
bool eeprom_model_service(eeprom_model_t *model, const uint8_t *torn);

/* Services until every persisted setting is stored; returns how many bytes it wrote. */
unsigned eeprom_model_flush(eeprom_model_t *model);

#endif
