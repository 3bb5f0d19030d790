/* The persistent settings in two EEPROM slots. See nvm.h. */
#include "nvm.h"

#include <avr/eeprom.h>
#include <avr/io.h>
#include <stddef.h>
#include <string.h>

#include "dxl_image.h"

#define IMAGE_EEPROM_ADDR 0u

/* The slot being written (or last written): its bytes, its index and its next step. */
static uint8_t slot_bytes[DXL_IMAGE_SLOT_BYTES];
static uint8_t slot_index;
/* Steps of dxl_image_write_offset() still to compare; zero (all done) at reset, so the
 * firmware has no initialised data (no copy loop). */
static uint8_t steps_left;
/* The slot whose settings are in use and its sequence number (nvm_load, then each slot
 * written to its end). */
static uint8_t active_slot;
static uint8_t active_sequence;

static uint8_t *eeprom_addr(uint8_t slot, uint8_t offset) {
  return (uint8_t *)(uintptr_t)(IMAGE_EEPROM_ADDR + dxl_image_slot_offset(slot) + offset);
}

/* EE_READY (tiny_isr.S) only clears EERIE: while enabled it is raised for as long as the
 * EEPROM is ready; its job is to wake the main loop after a write. */

/* Not inlined: its frame holds both slots, which only boot needs (inlined into main, whose
 * frame lives for ever, it would deepen the stack of every later call). */
__attribute__((noinline)) const uint8_t *nvm_load(void) {
  /* Byte by byte: eeprom_read_byte() is linked anyway (nvm_service), eeprom_read_block() would
   * add 32 B of flash. */
  uint8_t image[DXL_IMAGE_BYTES];
  for (uint8_t offset = 0; offset < DXL_IMAGE_BYTES; offset++) {
    image[offset] = eeprom_read_byte(eeprom_addr(0, offset));
  }
  const uint8_t newest = dxl_image_newest_slot(image);
  if (newest == DXL_IMAGE_NO_SLOT) {
    active_slot = 1; /* the first write goes to slot 0 */
    return NULL;
  }
  memcpy(slot_bytes, &image[dxl_image_slot_offset(newest)], DXL_IMAGE_SLOT_BYTES);
  active_slot = newest;
  active_sequence = slot_bytes[DXL_IMAGE_OFS_SEQUENCE];
  return &slot_bytes[DXL_IMAGE_OFS_TABLE];
}

/* A store of eeprom_area into the slot not in use, with the next sequence number. */
static void start_store(const uint8_t *eeprom_area) {
  GPIOR0 &= (uint8_t)~_BV(NVM_PENDING_BIT);
  slot_index = (uint8_t)(active_slot ^ 1u);
  dxl_image_slot_build(slot_bytes, eeprom_area, (uint8_t)(active_sequence + 1u));
  steps_left = DXL_IMAGE_SLOT_BYTES;
}

/* Two returns, not one && (whose bit test gcc-avr 5.4 turns into a bool it then tests):
 * 22 B less flash on the ATmega88. */
bool nvm_work_ready(void) {
  if (steps_left == 0 || !eeprom_is_ready()) {
    return false;
  }
  return true;
}

bool nvm_busy(void) { return steps_left != 0 || nvm_persist_pending() || !eeprom_is_ready(); }

void nvm_service(const uint8_t *eeprom_area) {
  if (steps_left == 0) {
    if (!nvm_persist_pending()) {
      return;
    }
    start_store(eeprom_area);
  }
  while (nvm_work_ready()) {
    const uint8_t offset = dxl_image_write_offset((uint8_t)(DXL_IMAGE_SLOT_BYTES - steps_left--));
    uint8_t *const addr = eeprom_addr(slot_index, offset);
    const uint8_t value = slot_bytes[offset];
    if (steps_left == 0) {
      /* The sequence number (written now, or already right): this slot is in use. */
      active_slot = slot_index;
      active_sequence = value;
    }
    if (eeprom_read_byte(addr) != value) {
      eeprom_write_byte(addr, value);
      EECR |= _BV(EERIE);
      return;
    }
  }
}
