/* The board functions the link layer (dxl_link.h) calls, defined by whoever runs it: the
 * firmware (firmware/app/link_port.c, over hal/uart.h) and the host tests (a fake UART). port
 * is the caller's handle, passed through unchanged (the firmware has one servo and passes
 * NULL). Every function is called from the main loop only.
 *
 * The seam is the UART as the link layer sees it: a receive ring the RX interrupt fills, the
 * reply the UART sends at its Return Delay Time, and the RX interrupt's sniff, which frames a
 * packet for this servo as it arrives and arms its reply (docs/firmware.md "Reply timing").
 * A port without a sniff keeps its state at DXL_LINK_SNIFF_OFF: every packet then goes
 * through the packet finder and is answered from the main loop.
 */
#ifndef DXL_LINK_PORT_H
#define DXL_LINK_PORT_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_packet.h"
#include "dxl_servo.h"

/* Reply states (dxl_link_port_reply_state). IDLE -> ARMED (the link loads and the sniff arms)
 * -> IDLE (checksum differs; disarm) or -> WAITING / SENDING (the checksum matched); IDLE ->
 * WAITING / SENDING (reply_start); WAITING -> SENDING (at the Return Delay Time); SENDING ->
 * DONE (the last stop bit has left, the bus is released); DONE -> IDLE (reply_finish). */
#define DXL_LINK_REPLY_IDLE 0u
#define DXL_LINK_REPLY_ARMED 1u
#define DXL_LINK_REPLY_WAITING 2u
#define DXL_LINK_REPLY_SENDING 3u
#define DXL_LINK_REPLY_DONE 4u

/* Sniff states (dxl_link_port_sniff_state): 0 = waiting for a packet's first byte; 1 ..
 * DXL_LINK_SNIFF_LENGTH = within a header, which it holds in its own state, not in the ring;
 * above that and below ARMED = framing the rest of a packet it keeps, whose bytes it holds in
 * the ring (the link leaves the ring alone); ARMED = it armed the reply of the packet that
 * ends just before dxl_link_port_sniff_end(); OFF = not running, the ring is the link's. */
#define DXL_LINK_SNIFF_WAITING 0u
#define DXL_LINK_SNIFF_LENGTH 3u
#define DXL_LINK_SNIFF_ARMED 8u
#define DXL_LINK_SNIFF_OFF 0xFFu

/* Receive ring: bytes received and bytes taken since power-up, each mod 256 (the ring holds
 * head - tail bytes). */
uint8_t dxl_link_port_rx_head(void *port);
uint8_t dxl_link_port_rx_tail(void *port);
/* Copies the count oldest bytes of the ring to dst (count <= head - tail) and takes them. */
void dxl_link_port_rx_take(void *port, uint8_t *dst, uint8_t count);

/* The sniff. start: with the ready PING reply loaded, the reply IDLE and the ring empty (it
 * does nothing otherwise), frame the packets that come, arming the reply of one for id whose
 * instruction's bit is set in mask. adopt: ARMED -> OFF, the link takes the armed packet over.
 * stop_part_way: a sniff past its header (not one that has armed) stops, what it held is the
 * link's. restart_if: if the state is still state (a header part-way), it drops the header and
 * waits for a packet's first byte again. end: the ring position just after the armed packet's
 * checksum. */
uint8_t dxl_link_port_sniff_state(void *port);
void dxl_link_port_sniff_start(void *port, uint8_t id, uint8_t mask);
void dxl_link_port_sniff_adopt(void *port);
void dxl_link_port_sniff_stop_part_way(void *port);
void dxl_link_port_sniff_restart_if(void *port, uint8_t state);
uint8_t dxl_link_port_sniff_end(void *port);
/* Bytes of another servo's packet the RX interrupt still passes over (0: none); skip_end
 * stops that. */
uint8_t dxl_link_port_skip_count(void *port);
void dxl_link_port_skip_end(void *port);

/* The reply. load: the status packet to send next, bytes[0..length) (kept unchanged by the
 * link until the state is DONE), and its delay after the packet's last byte, delay_us (2 us x
 * Return Delay Time); state IDLE. start: sends it delay_us after the last byte taken from the
 * ring, at once if that has passed. publish: a streamed reply's bytes[0..length) are final.
 * disarm: ARMED -> IDLE, false when the reply had already started. */
void dxl_link_port_reply_load(void *port, const uint8_t *bytes, uint8_t length, uint16_t delay_us);
void dxl_link_port_reply_start(void *port);
void dxl_link_port_reply_publish(void *port, uint8_t length);
bool dxl_link_port_reply_disarm(void *port);
uint8_t dxl_link_port_reply_state(void *port);
void dxl_link_port_reply_finish(void *port);

/* The millisecond clock (wrapping at 2^16). */
uint16_t dxl_link_port_now_ms(void *port);

/* The link has more work for its next pass: no idle sleep before it. */
void dxl_link_port_wake(void *port);

/* A packet (found: DXL_FIND_PACKET or DXL_FIND_BAD_CHECKSUM) has been handled: response is
 * what the servo made of it, its reply (if any) started. bytes[0..length) is the packet as
 * framed (FF FF ID LENGTH ... CHECKSUM). For observers; the firmware's does nothing. */
void dxl_link_port_handled(void *port, dxl_find_result_t found, const uint8_t *bytes, uint16_t length,
                           const dxl_response_t *response);

#endif
