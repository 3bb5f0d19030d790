#include "dxl_link.h"

#include <string.h>

#include "dxl_after.h"
#include "dxl_config.h"
#include "dxl_link_port.h"
#include "dxl_protocol.h"
#include "dxl_table.h"

static bool link_free(const dxl_link_t *link) {
  return dxl_link_port_reply_state(link->port) == DXL_LINK_REPLY_IDLE;
}

/* The packet the finder returned (or, on the armed path, completes) as framed: it is still
 * at the front of the finder's bytes, FF FF ID LENGTH and LENGTH bytes more. */
#define FRAMED_HEADER_BYTES 4u
#define FRAMED_OFS_LENGTH 3u
static void report_handled(dxl_link_t *link, dxl_find_result_t found) {
  const uint8_t *bytes = dxl_finder_held(&link->finder);
  dxl_link_port_handled(link->port, found, bytes, (uint16_t)(FRAMED_HEADER_BYTES + bytes[FRAMED_OFS_LENGTH]),
                        &link->response);
}

/* Starts the prepared (or rejected) packet's reply, its bytes final once prepared; what must
 * follow its end (dxl_after.h) is kept for dxl_link_service_reply(). */
static DXL_ONE_COPY void start_reply(dxl_link_t *link) {
  link->after_reply = link->response.after;
  dxl_link_port_reply_load(link->port, link->response.bytes, link->response.length, link->response.delay_us);
  dxl_link_port_reply_start(link->port);
}

/* Whether the armed packet's reply is the streamed one the link prepares and commits (else a
 * PING answered with the ready reply, which needs nothing). Two returns, not one || (whose
 * bool gcc-avr 5.4 builds and then tests): 30 B less flash on the ATmega88. */
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
    start_reply(link);
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
    start_reply(link);
  }
  report_handled(link, DXL_FIND_BAD_CHECKSUM);
}

/* Starts the sniff when nothing is held or under way: the finder holds no byte, the ring is
 * empty (the port checks), the link idle and nothing armed, so the next byte is where the
 * finder would start its candidate (the sniff never answers a packet the finder would not
 * see), and every earlier packet is committed (the sniff decides with the table of the
 * moment). Callers: nothing armed. */
static void sniff_start(dxl_link_t *link, dxl_servo_t *servo) {
  if (dxl_link_port_sniff_state(link->port) == DXL_LINK_SNIFF_OFF && link_free(link) &&
      dxl_finder_idle(&link->finder)) {
    /* The delay from the table: after a packet that got no reply (another servo's, a broadcast
     * PING of profile ax12a) the response holds the PING reply's bytes beside a header that
     * dxl_servo_prepare() cleared, delay 0 included. */
    const uint8_t *table = servo->table;
    dxl_link_port_reply_load(link->port, link->response.bytes, DXL_PING_REPLY_BYTES,
                             (uint16_t)(DXL_RETURN_DELAY_UNIT_US * table[CT_ADDR_RETURN_DELAY_TIME]));
    dxl_link_port_sniff_start(link->port, table[CT_ADDR_ID], dxl_servo_stream_mask(servo));
  }
}

/* Rebuilds and reloads the ready PING reply when the link is idle and nothing is armed (so
 * nothing reads it meanwhile), then starts the sniff. A sniff that has matched some bytes is
 * left alone: its PING is under way with this reply. One still at its first byte keeps
 * running (stopping it would miss a PING that starts meanwhile): it reads the reply at the
 * PING's checksum, at least 5 byte times later (800 cycles at 1 Mbps), long after the rebuild
 * and the reload are done. */
static void refresh_ping_reply(dxl_link_t *link, dxl_servo_t *servo) {
  const uint8_t sniff = dxl_link_port_sniff_state(link->port);
  if (!link->armed && link_free(link) && (sniff == DXL_LINK_SNIFF_WAITING || sniff == DXL_LINK_SNIFF_OFF)) {
    dxl_servo_ping_reply(servo, &link->response);
    dxl_link_port_reply_load(link->port, link->response.bytes, DXL_PING_REPLY_BYTES, link->response.delay_us);
    sniff_start(link, servo);
  }
}

/* The sniff armed a reply at a packet's last byte but one: the link takes it over. */
static DXL_ONE_COPY void adopt_sniffed(dxl_link_t *link) {
  if (!link->armed && dxl_link_port_sniff_state(link->port) == DXL_LINK_SNIFF_ARMED) {
    dxl_link_port_sniff_adopt(link->port);
    link->armed = true;
  }
}

/* Bytes of the armed packet still in the ring or on the wire, its checksum included. One copy
 * for its two tests (4 B less flash on the ATmega88). */
static DXL_ONE_COPY uint8_t armed_bytes_left(const dxl_link_t *link) {
  return (uint8_t)(dxl_link_port_sniff_end(link->port) - dxl_link_port_rx_tail(link->port));
}

/* Moves up to max_bytes waiting in the ring into the finder (as far as it has room), stamped
 * with the current millisecond, in one batch; the finder examines them in one
 * dxl_finder_next() pass. Returns how many moved. */
static uint8_t push_waiting_bytes(dxl_link_t *link, uint8_t max_bytes) {
  const uint16_t now_ms = dxl_link_port_now_ms(link->port);
  uint16_t room;
  uint8_t *slot = dxl_finder_push_slot(&link->finder, &room, now_ms);
  uint8_t count = (uint8_t)(dxl_link_port_rx_head(link->port) - dxl_link_port_rx_tail(link->port));
  if (!link->armed && dxl_link_port_sniff_state(link->port) != DXL_LINK_SNIFF_OFF) {
    /* Read after the head: the sniff holds the ring (it may drop a packet from it), or armed
     * at a byte already counted, whose packet goes through the armed path (adopt_sniffed). */
    return 0;
  }
  if (count > max_bytes) {
    count = max_bytes;
  }
  if (count > room) {
    count = (uint8_t)room;
  }
  dxl_link_port_rx_take(link->port, slot, count);
  dxl_finder_pushed(&link->finder, count, now_ms);
  return count;
}

/* The armed packet: everything but the checksum goes to the finder first, and the reply is
 * prepared then, while the checksum is still on the wire. A PING answers with the ready reply;
 * anything else streamed its header and waits for the rest, published here (dxl_servo.h
 * "Streamed replies": the prepared reply of such a packet is non-empty with nothing after
 * it). Returns false when the bytes it needs are still on the wire. */
static bool service_armed(dxl_link_t *link, dxl_servo_t *servo) {
  dxl_packet_t packet;
  const uint8_t left = armed_bytes_left(link);
  if (left > 1) {
    if (push_waiting_bytes(link, (uint8_t)(left - 1u)) == 0) {
      return false;
    }
    (void)dxl_finder_next(&link->finder, &packet); /* the same candidate as the sniff: NONE */
    if (armed_bytes_left(link) == 1) {
      dxl_finder_candidate(&link->finder, &packet);
      if (reply_is_streamed(&packet)) {
        dxl_servo_prepare(servo, &packet, &link->response);
        dxl_link_port_reply_publish(link->port, link->response.length);
      }
    }
    return true;
  }
  if (push_waiting_bytes(link, 1) == 0) {
    return false; /* the checksum byte is still on the wire */
  }
  link->finder_dirty = true;
  link->armed = false;
  if (!link_free(link)) {
    /* The checksum matched and the reply is under way: the finder completes the same packet
     * (DXL_FIND_PACKET); commit what was prepared. */
    (void)dxl_finder_next(&link->finder, &packet);
    if (reply_is_streamed(&packet)) {
      commit(link, servo); /* a store at most follows it */
    } /* else a PING: the response is the ready reply the UART sent */
    report_handled(link, DXL_FIND_PACKET);
    link->after_reply = 0;
    link->finder_dirty = false;
    /* The reply may be DONE already (a control tick ran meanwhile), which
     * dxl_link_service_reply() left alone while this was armed: another pass takes it at once,
     * not at the next wake (the sniff would stay off until then). */
    dxl_link_port_wake(link->port);
  } else {
    refresh_ping_reply(link, servo); /* nothing was sent; a prepared reply may have taken the buffer */
  }
  return true; /* a mismatch is handled next like any byte */
}

void dxl_link_service_rx(dxl_link_t *link, dxl_servo_t *servo) {
  dxl_packet_t packet;
  for (;;) {
    adopt_sniffed(link);
    if (link->armed) {
      if (!service_armed(link, servo)) {
        return;
      }
      continue;
    }
    if (!link_free(link)) {
      return; /* one reply at a time: the rest waits in the ring */
    }
    if (link->finder_dirty) {
      const dxl_find_result_t found = dxl_finder_next(&link->finder, &packet);
      if (found == DXL_FIND_NONE) {
        link->finder_dirty = false;
        /* Back to the main loop (watchdog, tick) between batches: at once when bytes came
         * meanwhile (or waited for a reply's end), else with the sniff listening. */
        if (dxl_link_port_rx_head(link->port) != dxl_link_port_rx_tail(link->port)) {
          dxl_link_port_wake(link->port);
        } else {
          sniff_start(link, servo);
        }
        return;
      }
      if (found == DXL_FIND_PACKET) {
        on_packet(link, servo, &packet);
      } else {
        on_bad_checksum(link, servo, &packet);
      }
      /* The ready PING reply is rebuilt when the packet changed something (a reply that used
       * the buffer rebuilds it when it has left); another servo's packet, the usual case on a
       * busy bus, changes nothing. */
      if (link->response.action != DXL_ACTION_NONE) {
        refresh_ping_reply(link, servo);
      }
      if (found == DXL_FIND_BAD_CHECKSUM) {
        /* One rejected candidate a pass: a flood of garbage cannot starve the control tick. */
        dxl_link_port_wake(link->port);
        return;
      }
    } else if (dxl_link_port_rx_head(link->port) != dxl_link_port_rx_tail(link->port) &&
               push_waiting_bytes(link, UINT8_MAX) != 0) {
      link->finder_dirty = true;
    } else if (dxl_link_port_sniff_state(link->port) == DXL_LINK_SNIFF_ARMED) {
      continue; /* adopt it */
    } else {
      sniff_start(link, servo);
      return;
    }
  }
}

void dxl_link_service_reply(dxl_link_t *link, dxl_servo_t *servo) {
  adopt_sniffed(link); /* before DONE is taken for a reply of its own */
  if (!link->armed && dxl_link_port_reply_state(link->port) == DXL_LINK_REPLY_DONE) {
    dxl_link_port_reply_finish(link->port);
    const uint8_t after = link->after_reply;
    link->after_reply = 0;
    dxl_after_reply(servo, after, link->port);
    refresh_ping_reply(link, servo);
  }
}

/* A packet the sniff holds (part-way past its header, or an armed reply whose checksum does
 * not come) is given up after DXL_LINK_SNIFF_MAX_MS without a byte, long before the finder's
 * gap timeout could split it: its bytes go to the finder, which applies the gap rule. */
static void sniff_timeout(dxl_link_t *link, dxl_servo_t *servo, uint8_t sniff) {
  const uint8_t head = dxl_link_port_rx_head(link->port);
  if ((link->armed || (sniff > DXL_LINK_SNIFF_LENGTH && sniff < DXL_LINK_SNIFF_ARMED)) &&
      head == link->sniff_seen_head) {
    if (++link->sniff_age_ms >= DXL_LINK_SNIFF_MAX_MS) {
      dxl_link_port_sniff_stop_part_way(link->port);
      if (link->armed && dxl_link_port_reply_disarm(link->port)) {
        link->armed = false;
        refresh_ping_reply(link, servo); /* a streamed reply may have been prepared into its buffer */
      }
    }
  } else {
    link->sniff_age_ms = 0;
    link->sniff_seen_head = head;
  }
}

/* Another servo's packet the RX interrupt passes over, and a header the sniff frames without
 * storing it, end like any partial packet when no byte came for more than
 * DXL_PACKET_GAP_TIMEOUT_MS (docs/policy.md "Framing and bus"): the skip stops, the header is
 * dropped, as the finder drops what came before a gap. Progress is the skip count or the
 * header state changing between ticks (bytes that bring it back to the same value within 1 ms
 * every time for 100 ms could end either early: the rest then reaches the sniff or the finder,
 * which frame nothing of it). */
static void quiet_timeout(dxl_link_t *link, uint8_t sniff) {
  const uint8_t skip = dxl_link_port_skip_count(link->port);
  const uint8_t quiet = skip != 0 ? skip : (sniff <= DXL_LINK_SNIFF_LENGTH ? sniff : 0u);
  if (quiet != 0 && quiet == link->quiet_seen) {
    if (++link->quiet_age_ms > DXL_PACKET_GAP_TIMEOUT_MS) {
      /* A byte just now would have come after the gap: not the packet's. */
      dxl_link_port_skip_end(link->port);
      dxl_link_port_sniff_restart_if(link->port, sniff);
    }
  } else {
    link->quiet_seen = quiet;
    link->quiet_age_ms = 0;
  }
}

void dxl_link_tick(dxl_link_t *link, dxl_servo_t *servo, uint16_t now_ms) {
  const uint8_t sniff = dxl_link_port_sniff_state(link->port);
  sniff_timeout(link, servo, sniff);
  quiet_timeout(link, sniff);
  /* Not while a rescan is pending (bytes pushed or a result taken, replies holding up the
   * rest): the finder marks one gap, and a poll then could move the mark past bytes that came
   * after it, joining them to the bytes before it (docs/policy.md: no packet spans a gap).
   * No byte is pushed before the rescan is done (the armed path's go into a finder with
   * nothing to rescan), so the gap is polled then, from the same last byte. */
  if (!link->armed && !link->finder_dirty) {
    link->finder_dirty = dxl_finder_poll(&link->finder, now_ms); /* rescan what came before the gap */
  }
}

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
