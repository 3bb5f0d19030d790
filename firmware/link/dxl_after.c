#include "dxl_after.h"

#include "dxl_after_port.h"
#include "dxl_table.h"

void dxl_after_commit(const dxl_servo_t *servo, uint8_t after, void *port) {
  if ((after & (DXL_AFTER_PERSIST | DXL_AFTER_FACTORY_RESET)) == DXL_AFTER_PERSIST) {
    dxl_after_port_persist(port, servo->table);
  }
}

void dxl_after_reply(dxl_servo_t *servo, uint8_t after, void *port) {
  if (after & DXL_AFTER_FACTORY_RESET) {
    /* A power cut while the defaults are stored keeps the settings before the RESET
     * (dxl_image.h): the servo comes back as it was, not half reset. */
    dxl_servo_factory_reset(servo);
    dxl_after_port_persist(port, servo->table);
  }
  if (after & DXL_AFTER_APPLY_BAUD) {
    dxl_after_port_set_baud(port, servo->table[CT_ADDR_BAUD_RATE]);
  }
#if DXL_HAS_BOOTLOADER
  if (after & DXL_AFTER_BOOTLOADER) {
    dxl_after_port_enter_bootloader(port);
  }
#endif
}
