/* The link layer: from received packets to packets handled and replies sent, for one servo.
 * Portable C; it reaches the UART through dxl_link_port.h and the board's after-reply
 * functions through dxl_after_port.h, and runs in the firmware's main loop and in the host
 * bus of the tests.
 *
 * What it owns (docs/firmware.md "The link layer", "Reply timing", "After the reply"):
 *   - the packet finder, fed from the receive ring in batches (the receiver has framed the
 *     packets there by the same rule, dxl_frame.h; the finder holds the one under way);
 *   - one reply at a time: a packet's reply is sent at its Return Delay Time
 *     (dxl_link_port_reply_send), and what follows it (dxl_after.h) runs once it has left;
 *     bytes that come meanwhile wait in the ring;
 *   - listening: when nothing is held or under way, the receiver is told to pass over other
 *     servos' packets and to arm the reply of this servo's; the ready PING reply (rebuilt
 *     whenever the link is idle and the table or the conditions change) is what it arms for a
 *     PING;
 *   - the armed path: when the receiver armed a reply at a packet's last byte but one, the
 *     reply is prepared and published while the checksum is still on the wire, and the packet
 *     committed once the checksum matched (a streamed reply, dxl_servo.h);
 *   - the gap: the receiver measures it (dxl_link_tick gives it the milliseconds); the link
 *     drops what it holds of a packet a gap ended.
 *
 * Use: dxl_link_init() once the servo is powered up, then in each main-loop pass
 * dxl_link_service_rx() (true: call it again without sleeping), and once per millisecond
 * dxl_link_tick() and, after the control tick, dxl_link_conditions_changed(). A pass with
 * nothing to do is one port call and a few tests. */
#ifndef DXL_LINK_H
#define DXL_LINK_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_packet.h"
#include "dxl_servo.h"

typedef struct {
  void *port;
  dxl_finder_t finder;
  /* The reply being prepared, armed or sent; while the link is idle it holds the ready reply
   * to a PING, whose first bytes FF FF ID also start a streamed reply. */
  dxl_response_t response;
  uint8_t armed;       /* LINK_ARMED_* (dxl_link.c): the receiver armed the reply of the packet
                          the finder is framing */
  uint8_t after_reply; /* DXL_AFTER_* to apply once the reply has left */
  bool listening;      /* the receiver listens (dxl_link_port_listen) and has kept no byte since */
} dxl_link_t;

/* servo powered up (dxl_servo_power_up); loads the ready PING reply and listens. */
void dxl_link_init(dxl_link_t *link, dxl_servo_t *servo, void *port);

/* After a reply's last byte: what follows it (dxl_after_reply), then the ready PING reply.
 * dxl_link_service_rx() does this first; a host may call it on its own to see the order. */
void dxl_link_service_reply(dxl_link_t *link, dxl_servo_t *servo);

/* What follows a reply that has left (dxl_link_service_reply), then bytes from the ring through
 * the finder to the servo, replies started. Returns when the ring is empty, a reply is under
 * way or a packet has been handled (one a call, so the caller's other work runs between
 * packets): true when the link wants another pass at once. */
bool dxl_link_service_rx(dxl_link_t *link, dxl_servo_t *servo);

/* Once per millisecond: the receiver's gap rule. */
void dxl_link_tick(dxl_link_t *link);

/* After a control tick that returned conditions (the error byte of a status packet): the
 * ready PING reply is rebuilt when its error byte differs. */
void dxl_link_conditions_changed(dxl_link_t *link, dxl_servo_t *servo, uint8_t conditions);

#endif
