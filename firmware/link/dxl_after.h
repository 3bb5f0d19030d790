/* What follows a handled packet, and in which order: the one statement of the after-reply
 * policy (docs/firmware.md "After the reply"), run by the firmware's main loop and by the
 * host bus of the tests. Portable C; it reaches the board through dxl_after_port.h.
 *
 * A prepared response says what its packet changes beyond the table (response.after,
 * DXL_AFTER_*). Those changes are split around the reply, whose bytes are final once prepared
 * and which starts at its Return Delay Time whatever follows it:
 *   when the packet is committed (dxl_after_commit), before, during or after its reply: a
 *     write of the EEPROM area starts being stored, in the background (the reply does not
 *     wait for it; dxl_image.h says how a power cut meanwhile keeps the old settings);
 *   after the reply's last stop bit, or at once when there is no reply (dxl_after_reply):
 *     RESET's factory defaults, stored; then a new Baud Rate, so the reply itself still
 *     leaves at the baud the request came at.
 */
#ifndef DXL_AFTER_H
#define DXL_AFTER_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_servo.h"

/* True when something must wait for the reply's end: RESET's defaults or a new baud. A
 * packet whose after is otherwise (nothing, or only a store) can be answered and committed in
 * any order. */
static inline bool dxl_after_waits_for_reply(uint8_t after) {
  return (after & (DXL_AFTER_FACTORY_RESET | DXL_AFTER_APPLY_BAUD | DXL_AFTER_BOOTLOADER)) != 0;
}

/* Right after dxl_servo_commit(): starts storing the EEPROM area when the packet wrote it
 * (RESET stores its defaults after the reply instead). */
void dxl_after_commit(const dxl_servo_t *servo, uint8_t after, void *port);

/* What follows the reply: factory reset (then stored), then the new baud; or, for
 * DXL_INST_BOOTLOADER, the bootloader (the port's job: it waits for any store under way and
 * does not return). */
void dxl_after_reply(dxl_servo_t *servo, uint8_t after, void *port);

#endif
