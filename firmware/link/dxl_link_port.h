/* The board functions the link layer (dxl_link.h) calls to reach the UART, defined by whoever
 * runs it: the firmware (firmware/hal/link_port.c, over hal/uart.h) and the host tests (a fake
 * UART). Together with dxl_after_port.h they are the whole seam between the link and the
 * board. port is the caller's handle, passed through unchanged (the firmware has one servo and
 * passes NULL). Every function is called from the main loop only.
 *
 * The receiver (the firmware's RX interrupt) frames every byte by the one rule (dxl_frame.h)
 * and puts into the receive ring the packets this servo keeps, each as FF FF ID LENGTH and the
 * LENGTH bytes after it: garbage, extra 0xFF, Protocol 2.0 frames and packets passed over never
 * reach the ring. While the link listens (dxl_link_port_listen), the receiver passes over
 * packets for other IDs without waking the main loop, and arms the reply of a packet for the
 * link's ID at its last byte but one, to start it the moment the checksum comes and matches
 * (docs/firmware.md "Reply timing"). A port that never arms is correct too: every reply then
 * starts from the link (dxl_link_port_reply_send). */
#ifndef DXL_LINK_PORT_H
#define DXL_LINK_PORT_H

#include <stdbool.h>
#include <stdint.h>

#include "dxl_config.h"
#include "dxl_packet.h"
#include "dxl_servo.h"

/* dxl_link_port_state(): the reply's state in the low bits, DXL_LINK_RX_BYTES, DXL_LINK_RX_GAP,
 * DXL_LINK_RX_ARMED and DXL_LINK_RX_BUSY.
 * Reply: IDLE -> ARMED (the receiver, while listening) -> IDLE (its checksum differed, or a gap
 * ended it) or -> WAITING / SENDING (it matched); IDLE -> WAITING / SENDING (reply_send);
 * WAITING -> SENDING (at the Return Delay Time); SENDING -> DONE (the last stop bit has left,
 * the bus is released); DONE -> IDLE (reply_finish). */
#define DXL_LINK_REPLY_MASK 0x07u
#define DXL_LINK_REPLY_IDLE 0u
#define DXL_LINK_REPLY_ARMED 1u
#define DXL_LINK_REPLY_WAITING 2u
#define DXL_LINK_REPLY_SENDING 3u
#define DXL_LINK_REPLY_DONE 4u
/* The receive ring holds bytes. */
#define DXL_LINK_RX_BYTES 0x10u
/* A gap of more than DXL_PACKET_GAP_TIMEOUT_MS ended the packet under way where the bytes taken
 * so far end: the link drops what it holds of it before it takes more (the next
 * dxl_link_port_rx_take clears this). */
#define DXL_LINK_RX_GAP 0x20u
/* The receiver armed the reply of a packet whose last byte the link has not taken from the ring
 * yet (whatever the reply's state has become meanwhile). */
#define DXL_LINK_RX_ARMED 0x40u
/* The receiver is between a header's ID and its packet's checksum (dxl_frame_in_packet): while
 * listening, a reply could be armed a few byte times from now, so the listen reply must not
 * change. Before a header's ID, in a skip or in a Protocol 2.0 frame it may: a PING's checksum
 * is then at least four byte times away. */
#define DXL_LINK_RX_BUSY 0x80u

uint8_t dxl_link_port_state(void *port);

/* Copies up to max of the oldest bytes of the receive ring to dst and takes them, never past
 * the point where a gap ended a packet (DXL_LINK_RX_GAP), nor an armed packet's checksum before
 * dxl_link_port_reply_publish(); returns how many. */
uint8_t dxl_link_port_rx_take(void *port, uint8_t *dst, uint8_t max);

/* Once per millisecond: the receiver's end of the gap rule. When no byte has come for more than
 * DXL_PACKET_GAP_TIMEOUT_MS while it was inside a header, a packet or a skip, it drops that (a
 * reply it armed goes back to IDLE), the next byte starts a search, and the bytes in the ring so
 * far end at the gap. */
void dxl_link_port_rx_tick(void *port);

/* With the reply IDLE and the ring empty (else it does nothing and returns false): ping_reply
 * (DXL_PING_REPLY_BYTES, kept unchanged by the link while it listens and nothing is armed,
 * except when the state is not DXL_LINK_RX_BUSY) becomes the reply, delay_us after the
 * packet's last byte, and the receiver listens: it passes over packets for other IDs and arms
 * the reply of one for id whose instruction's bit is set in mask (dxl_servo_stream_mask): a
 * PING answered with ping_reply, anything else streaming its first DXL_STREAM_HEADER_BYTES
 * until dxl_link_port_reply_publish(). The first packet it keeps (this servo's or broadcast)
 * ends the listening: the next ones are all kept until the link listens again. */
bool dxl_link_port_listen(void *port, const uint8_t *ping_reply, uint16_t delay_us, uint8_t id, uint8_t mask);

/* State IDLE: sends bytes[0..length) (kept unchanged by the link until the state is DONE)
 * delay_us after the last byte taken from the ring (2 us x Return Delay Time), at once if that
 * has passed. */
void dxl_link_port_reply_send(void *port, const uint8_t *bytes, uint8_t length, uint16_t delay_us);

/* An armed or started streamed reply's bytes[0..length) are final (an armed PING's: the ping
 * reply's DXL_PING_REPLY_BYTES), and an armed packet's checksum may be taken. */
void dxl_link_port_reply_publish(void *port, uint8_t length);

/* DONE -> IDLE, once the link has acted on what follows the reply. */
void dxl_link_port_reply_finish(void *port);

#if DXL_LINK_OBSERVER
/* Not a board function: the host's observer (tests, the conformance log). A packet (found:
 * DXL_FIND_PACKET or DXL_FIND_BAD_CHECKSUM) has been handled: response is what the servo made
 * of it, its reply (if any) started. bytes[0..length) is the packet as framed (FF FF ID LENGTH
 * ... CHECKSUM). */
void dxl_link_port_handled(void *port, dxl_find_result_t found, const uint8_t *bytes, uint16_t length,
                           const dxl_response_t *response);
#endif

#endif
