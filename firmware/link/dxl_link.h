/* The link layer: from received bytes to packets handled and replies sent, for one servo.
 * Portable C; it reaches the UART through dxl_link_port.h and the board's after-reply
 * functions through dxl_after_port.h, and runs in the firmware's main loop and in the host
 * bus of the tests.
 *
 * What it owns (docs/firmware.md "Receive", "Reply timing", "After the reply"):
 *   - the packet finder, fed from the receive ring in batches;
 *   - one reply at a time: a packet's reply is loaded and started at its Return Delay Time
 *     (dxl_link_port_reply_start), and what follows it (dxl_after.h) runs once it has left;
 *     bytes that come meanwhile wait in the ring;
 *   - the armed path: when the port's sniff armed a reply at a packet's last byte but one,
 *     the reply is prepared and published while the checksum is still on the wire, and the
 *     packet committed once the checksum matched (a streamed reply, dxl_servo.h);
 *   - the ready PING reply (response, rebuilt whenever the link is idle and the table or the
 *     conditions change), which the sniff answers a PING with;
 *   - the timeouts: a sniff that holds bytes and gets none for DXL_LINK_SNIFF_MAX_MS gives
 *     them to the finder; a header part-way or a skip of another servo's packet ends after a
 *     gap of more than DXL_PACKET_GAP_TIMEOUT_MS, as the finder ends a partial packet.
 *
 * Use: dxl_link_init() once the servo is powered up, then in each main-loop pass
 * dxl_link_service_reply(), dxl_link_service_rx(), and once per millisecond dxl_link_tick()
 * and, after the control tick, dxl_link_conditions_changed(). Cost: a pass with nothing to do
 * is a few tests; a garbage flood is taken one rejected candidate a pass (its rescan can take
 * thousands of cycles), so it cannot starve the control tick.
 */
#ifndef DXL_LINK_H
#define DXL_LINK_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_packet.h"
#include "dxl_servo.h"

/* A sniff that holds bytes ends when no byte came for this long (a byte at 9600 baud takes
 * about 1 ms). The bytes it held then reach the finder stamped up to DXL_LINK_SNIFF_MAX_MS + 1
 * late, which is what the finder's 100 ms gap rule can be off by. */
#define DXL_LINK_SNIFF_MAX_MS 3u

typedef struct {
  void *port;
  dxl_finder_t finder;
  /* The reply being prepared, armed or sent; while the link is idle it holds the ready reply
   * to a PING, whose first bytes FF FF ID also start a streamed reply. */
  dxl_response_t response;
  bool armed;          /* the sniff armed the reply of the packet that ends just before
                          dxl_link_port_sniff_end(); the UART may already have started it */
  bool finder_dirty;   /* bytes pushed or a result taken since dxl_finder_next() last said
                          DXL_FIND_NONE */
  uint8_t after_reply; /* DXL_AFTER_* to apply once the reply has left */
  uint8_t sniff_age_ms;
  uint8_t sniff_seen_head; /* the ring's head at the last tick */
  uint8_t quiet_seen;      /* the skip count or header state at the last tick */
  uint8_t quiet_age_ms;
} dxl_link_t;

/* servo powered up (dxl_servo_power_up); loads the ready PING reply and starts the sniff. */
void dxl_link_init(dxl_link_t *link, dxl_servo_t *servo, void *port);

/* After a reply's last byte: what follows it (dxl_after_reply), then the ready PING reply. */
void dxl_link_service_reply(dxl_link_t *link, dxl_servo_t *servo);

/* Bytes from the ring through the finder to the servo; replies started. Returns when the
 * ring is empty, a reply is under way, or after one rejected candidate (then it has called
 * dxl_link_port_wake). */
void dxl_link_service_rx(dxl_link_t *link, dxl_servo_t *servo);

/* Once per millisecond: the timeouts, the finder's gap. */
void dxl_link_tick(dxl_link_t *link, dxl_servo_t *servo, uint16_t now_ms);

/* After a control tick that returned conditions (the error byte of a status packet): the
 * ready PING reply is rebuilt when its error byte differs. */
void dxl_link_conditions_changed(dxl_link_t *link, dxl_servo_t *servo, uint8_t conditions);

#endif
