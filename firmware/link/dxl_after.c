#include "dxl_after.h"

#include "dxl_after_port.h"
#include "dxl_table.h"

bool dxl_after_before_reply(const dxl_servo_t *servo, uint8_t after, void *port) {
  if (!dxl_after_persists_first(after)) {
    return false;
  }
  dxl_after_port_persist(port, servo->table);
  return true;
}

void dxl_after_reply(dxl_servo_t *servo, uint8_t after, void *port) {
  if (after & DXL_AFTER_FACTORY_RESET) {
    /* A power cut while the defaults are stored leaves an image whose CRC fails, which boots
     * the same defaults. */
    dxl_servo_factory_reset(servo);
    dxl_after_port_persist(port, servo->table);
  }
  if (after & DXL_AFTER_APPLY_BAUD) {
    dxl_after_port_set_baud(port, servo->table[CT_ADDR_BAUD_RATE]);
  }
}
