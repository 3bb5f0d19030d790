#include "dxl_link.h"

#include <string.h>

#include "dxl_after.h"
#include "dxl_config.h"
#include "dxl_link_port.h"
#include "dxl_protocol.h"
#include "dxl_table.h"

/* link->armed: the packet whose reply the receiver armed, as the link takes it. */
#define LINK_ARMED_NONE 0u
#define LINK_ARMED_TAKING 1u   /* its bytes are coming */
#define LINK_ARMED_PREPARED 2u /* all but its checksum are in; a streamed reply is published */

static uint8_t reply_state(const dxl_link_t *link) { return dxl_link_port_state(link->port) & DXL_LINK_REPLY_MASK; }

/* The packet the finder completed, as framed: at the front of the finder's bytes, FF FF ID
 * LENGTH and LENGTH bytes more. */
static void report_handled(dxl_link_t *link, dxl_find_result_t found) {
#if DXL_LINK_OBSERVER
  const uint8_t *bytes = dxl_finder_held(&link->finder);
  dxl_link_port_handled(link->port, found, bytes, (uint16_t)(DXL_PACKET_HEADER_BYTES + bytes[3]), &link->response);
#else
  (void)link;
  (void)found;
#endif
}

/* Sends the prepared (or rejected) packet's reply, its bytes final once prepared; what must
 * follow its end (dxl_after.h) is kept for dxl_link_service_reply(). */
static DXL_ONE_COPY void send_reply(dxl_link_t *link) {
  link->after_reply = link->response.after;
  dxl_link_port_reply_send(link->port, link->response.bytes, link->response.length, link->response.delay_us);
}

/* Whether the armed packet's reply is the streamed one the link prepares and commits (else a
 * PING answered with the ready reply, which needs nothing). */
static bool reply_is_streamed(const dxl_packet_t *packet) {
  if (packet->instruction != DXL_INST_PING) {
    return true;
  }
  return packet->param_count != 0;
}

/* The prepared packet's changes to the servo, and the store of the settings it wrote
 * (dxl_after_commit), once the reply's bytes are final. */
static DXL_ONE_COPY void commit(dxl_link_t *link, dxl_servo_t *servo) {
  dxl_servo_commit(servo, &link->response);
  dxl_after_commit(servo, link->response.after, link->port);
}

static void on_packet(dxl_link_t *link, dxl_servo_t *servo, const dxl_packet_t *packet) {
  dxl_response_t *response = &link->response;
  dxl_servo_prepare(servo, packet, response);
  if (response->length != 0) {
    send_reply(link);
  }
  commit(link, servo);
  report_handled(link, DXL_FIND_PACKET);
  if (response->length == 0) {
    dxl_after_reply(servo, response->after, link->port); /* no reply to wait for */
  }
}

static void on_bad_checksum(dxl_link_t *link, dxl_servo_t *servo, const dxl_packet_t *packet) {
  dxl_servo_reject_checksum(servo, packet, &link->response);
  if (link->response.length != 0) {
    send_reply(link);
  }
  report_handled(link, DXL_FIND_BAD_CHECKSUM);
}

/* Listens (dxl_link_port_listen) when nothing is held or under way: the finder idle, nothing
 * armed, and (the port checks) the reply IDLE and the ring empty, so
 * the next packet the receiver keeps is the next one the finder frames and every earlier one is
 * committed (the receiver arms with the table of the moment). The ready PING reply is in the
 * response's bytes; its delay comes from the table: after a packet that got no reply (another
 * servo's, a broadcast PING of profile ax12a) dxl_servo_prepare() has cleared the response's
 * header fields, delay included. */
static void listen(dxl_link_t *link, dxl_servo_t *servo) {
  if (link->armed == LINK_ARMED_NONE && dxl_finder_idle(&link->finder)) {
    const uint8_t *table = servo->table;
    link->listening = dxl_link_port_listen(link->port, link->response.bytes,
                               (uint16_t)(DXL_RETURN_DELAY_UNIT_US * table[CT_ADDR_RETURN_DELAY_TIME]), table[CT_ADDR_ID],
                               dxl_servo_stream_mask(servo));
  }
}

/* Rebuilds the ready PING reply and listens, when the reply is IDLE and nothing reads the
 * buffer meanwhile: nothing armed, and the receiver either not listening (it arms nothing then)
 * or not inside a header's ID, LENGTH or body (DXL_LINK_RX_BUSY): a PING it may still arm reads
 * the reply at its checksum, at least 4 byte times later (640 cycles at 1 Mbps), long after the
 * rebuild is done. A skip or a Protocol 2.0 frame may last many milliseconds: the conditions of
 * the ready reply follow the control tick through them. */
static void refresh_ping_reply(dxl_link_t *link, dxl_servo_t *servo) {
  const uint8_t state = dxl_link_port_state(link->port);
  const uint8_t busy = link->listening ? DXL_LINK_RX_BUSY : 0u;
  if (link->armed == LINK_ARMED_NONE &&
      (state & (DXL_LINK_REPLY_MASK | DXL_LINK_RX_ARMED | busy)) == DXL_LINK_REPLY_IDLE) {
    dxl_servo_ping_reply(servo, &link->response);
    listen(link, servo); /* again: the reply is reloaded */
  }
}

/* Whether the reply has left (DONE) and is the link's own (not one the receiver armed for a
 * packet whose last byte the link has still to take: dxl_link_service_rx completes it first). */
static bool reply_done(const dxl_link_t *link, uint8_t state) {
  return link->armed == LINK_ARMED_NONE &&
         (state & (DXL_LINK_REPLY_MASK | DXL_LINK_RX_ARMED)) == DXL_LINK_REPLY_DONE;
}

/* After the reply's last byte: what follows it, then the ready PING reply. */
static void reply_left(dxl_link_t *link, dxl_servo_t *servo) {
  dxl_link_port_reply_finish(link->port);
  const uint8_t after = link->after_reply;
  link->after_reply = 0;
  dxl_after_reply(servo, after, link->port);
  refresh_ping_reply(link, servo);
}

bool dxl_link_service_rx(dxl_link_t *link, dxl_servo_t *servo) {
  for (;;) {
    uint8_t state = dxl_link_port_state(link->port);
    if (reply_done(link, state)) {
      reply_left(link, servo);
      state = dxl_link_port_state(link->port);
    }
    if (state & DXL_LINK_RX_GAP) {
      /* A gap's point: what the finder holds of the packet under way there is dropped (the
       * receiver has withdrawn a reply it armed for it). */
      dxl_finder_gap(&link->finder);
      if (link->armed != LINK_ARMED_NONE) {
        link->armed = LINK_ARMED_NONE;
        refresh_ping_reply(link, servo); /* a streamed reply may have been prepared into its buffer */
        state = dxl_link_port_state(link->port);
      }
    }
    if (link->armed == LINK_ARMED_NONE) {
      if (state & DXL_LINK_RX_ARMED) {
        link->armed = LINK_ARMED_TAKING;
      } else if ((state & DXL_LINK_REPLY_MASK) != DXL_LINK_REPLY_IDLE) {
        return false; /* one reply at a time: the rest waits in the ring */
      } else if (link->listening && (state & DXL_LINK_RX_BYTES) == 0) {
        return false; /* nothing to take: the usual pass */
      }
    }
    if (link->armed == LINK_ARMED_TAKING && dxl_finder_left(&link->finder) == 1) {
      /* All but the checksum are in (perhaps taken before the receiver armed at the last of
       * them): prepare and publish the reply while the checksum is on the wire (dxl_servo.h
       * "Streamed replies"); a PING answers with the ready reply. */
      link->armed = LINK_ARMED_PREPARED;
      dxl_packet_t candidate;
      dxl_finder_candidate(&link->finder, &candidate);
      uint8_t length = DXL_PING_REPLY_BYTES;
      if (reply_is_streamed(&candidate)) {
        dxl_servo_prepare(servo, &candidate, &link->response);
        length = link->response.length;
      }
      dxl_link_port_reply_publish(link->port, length); /* the checksum may be taken now */
    }
    const bool body = dxl_finder_left(&link->finder) != 0;
    uint16_t want;
    uint8_t *slot = dxl_finder_slot(&link->finder, &want);
    const uint8_t taken = dxl_link_port_rx_take(link->port, slot, want > UINT8_MAX ? (uint8_t)UINT8_MAX : (uint8_t)want);
    if (taken == 0) {
      if (link->armed == LINK_ARMED_NONE && !link->listening) {
        listen(link, servo);
      }
      return false;
    }
    link->listening = false; /* the receiver keeps a packet only once it has stopped listening */
    dxl_packet_t packet;
    const dxl_find_result_t found = dxl_finder_pushed(&link->finder, taken, &packet);
    bool rebuild = false;
    if (found == DXL_FIND_NONE && body && link->armed == LINK_ARMED_NONE) {
      /* Part of a packet that comes byte by byte: the main loop's control tick runs between
       * its bytes, however long it is (back to back at 1 Mbps the ring is never empty). */
      return true;
    }
    if (link->armed != LINK_ARMED_NONE) {
      if (found == DXL_FIND_NONE) {
        continue;
      }
      link->armed = LINK_ARMED_NONE;
      if (reply_state(link) != DXL_LINK_REPLY_IDLE) {
        /* The checksum matched and the reply is under way: commit what was prepared. */
        if (reply_is_streamed(&packet)) {
          commit(link, servo); /* a store at most follows it */
        } /* else a PING: the response is the ready reply the UART sent */
        report_handled(link, DXL_FIND_PACKET);
        link->after_reply = 0;
        /* The reply may be DONE already (a control tick ran meanwhile), which
         * dxl_link_service_reply() left alone while this was armed: another pass takes it at
         * once, not at the next wake (the receiver would not listen until then). */
        return true;
      }
      rebuild = true; /* nothing was sent; a prepared reply may have taken the buffer */
    }
    if (found == DXL_FIND_PACKET) {
      on_packet(link, servo, &packet);
    } else if (found == DXL_FIND_BAD_CHECKSUM) {
      on_bad_checksum(link, servo, &packet);
    } else {
      continue;
    }
    /* The ready PING reply is rebuilt when the packet changed something (a reply that used the
     * buffer rebuilds it when it has left); another servo's packet changes nothing. */
    if (rebuild || link->response.action != DXL_ACTION_NONE) {
      refresh_ping_reply(link, servo);
    }
    return true; /* one packet a call: the control tick runs between packets too */
  }
}

void dxl_link_service_reply(dxl_link_t *link, dxl_servo_t *servo) {
  if (reply_done(link, dxl_link_port_state(link->port))) {
    reply_left(link, servo);
  }
}

void dxl_link_tick(dxl_link_t *link) { dxl_link_port_rx_tick(link->port); }

void dxl_link_conditions_changed(dxl_link_t *link, dxl_servo_t *servo, uint8_t conditions) {
  /* Anything else that changes the ready PING reply comes with a packet or a reply, which
   * rebuild it. */
  if (conditions != link->response.bytes[DXL_STATUS_ERROR_OFFSET]) {
    refresh_ping_reply(link, servo);
  }
}

void dxl_link_init(dxl_link_t *link, dxl_servo_t *servo, void *port) {
  memset(link, 0, sizeof *link); /* the finder's init too: dxl_finder_init() is this zeroing */
  link->port = port;
  refresh_ping_reply(link, servo);
}
