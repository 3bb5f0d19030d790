/* What follows a handled packet, and in which order: the one statement of the after-reply
 * policy (docs/firmware.md "After the reply"), run by the firmware's main loop and by the
 * host bus of the tests. Portable C; it reaches the board through dxl_after_port.h.
 *
 * A prepared response says what its packet changes beyond the table (response.after,
 * DXL_AFTER_*). Those changes are split around the reply:
 *   before the reply leaves: a write of the EEPROM area is stored (dxl_after_port_persist),
 *     so a reply proves that the settings survive a power cut (dxl_after_persists_first);
 *   after the reply's last stop bit, or at once when there is no reply (dxl_after_reply):
 *     RESET's factory defaults, stored; then a new Baud Rate, so the reply itself still
 *     leaves at the baud the request came at.
 */
#ifndef DXL_AFTER_H
#define DXL_AFTER_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_servo.h"

/* True when the EEPROM area must be stored before the reply starts: a write of it. A RESET
 * answers first and stores its defaults after the reply. */
static inline bool dxl_after_persists_first(uint8_t after) {
  return (after & DXL_AFTER_PERSIST) != 0 && (after & DXL_AFTER_FACTORY_RESET) == 0;
}

/* Stores the EEPROM area now if the reply must wait for it (dxl_after_persists_first), and
 * returns whether it did. */
bool dxl_after_before_reply(const dxl_servo_t *servo, uint8_t after, void *port);

/* What follows the reply: factory reset (then stored), then the new baud. */
void dxl_after_reply(dxl_servo_t *servo, uint8_t after, void *port);

#endif
