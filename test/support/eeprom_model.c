/* nvm.c on a byte array. See eeprom_model.h; the statements follow nvm.c's one for one. */
#include "eeprom_model.h"

#include <stddef.h>
#include <string.h>

static uint8_t *eeprom_addr(eeprom_model_t *m, uint8_t slot, uint8_t offset) {
  return &m->image[dxl_image_slot_offset(slot) + offset];
}

const uint8_t *eeprom_model_boot(eeprom_model_t *m) {
  /* A reset clears nvm.c's RAM (it has no initialised data). */
  memset(m->slot_bytes, 0, sizeof m->slot_bytes);
  m->slot_index = 0;
  m->steps_left = 0;
  m->active_slot = 0;
  m->active_sequence = 0;
  m->pending = false; /* GPIOR0 is cleared by a reset too */
  const uint8_t newest = dxl_image_newest_slot(m->image);
  if (newest == DXL_IMAGE_NO_SLOT) {
    m->active_slot = 1; /* the first write goes to slot 0 */
    return NULL;
  }
  memcpy(m->slot_bytes, eeprom_addr(m, newest, 0), DXL_IMAGE_SLOT_BYTES);
  m->active_slot = newest;
  m->active_sequence = m->slot_bytes[DXL_IMAGE_OFS_SEQUENCE];
  return &m->slot_bytes[DXL_IMAGE_OFS_TABLE];
}

void eeprom_model_persist(eeprom_model_t *m, const uint8_t *eeprom_area) {
  memcpy(m->pending_area, eeprom_area, CT_EEPROM_SIZE);
  m->pending = true;
}

bool eeprom_model_busy(const eeprom_model_t *m) { return m->steps_left != 0 || m->pending; }

bool eeprom_model_service(eeprom_model_t *m, const uint8_t *torn) {
  if (m->steps_left == 0) {
    if (!m->pending) {
      return false;
    }
    m->pending = false;
    m->slot_index = (uint8_t)(m->active_slot ^ 1u);
    dxl_image_slot_build(m->slot_bytes, m->pending_area, (uint8_t)(m->active_sequence + 1u));
    m->steps_left = DXL_IMAGE_SLOT_BYTES;
  }
  while (m->steps_left != 0) {
    const uint8_t offset = dxl_image_write_offset((uint8_t)(DXL_IMAGE_SLOT_BYTES - m->steps_left--));
    uint8_t *const addr = eeprom_addr(m, m->slot_index, offset);
    const uint8_t value = m->slot_bytes[offset];
    if (m->steps_left == 0) {
      /* nvm.c: the sequence number (written now, or already right): this slot is in use. */
      m->active_slot = m->slot_index;
      m->active_sequence = value;
    }
    if (*addr != value) {
      *addr = torn != NULL ? *torn : value;
      return true;
    }
  }
  return false;
}

unsigned eeprom_model_flush(eeprom_model_t *m) {
  unsigned written = 0;
  while (eeprom_model_busy(m)) {
    written += eeprom_model_service(m, NULL) ? 1u : 0u;
  }
  return written;
}
