#include "host_bus.h"

#include <string.h>

#include "conformance_log.h"
#include "dxl_after.h"
#include "dxl_after_port.h"
#include "dxl_protocol.h"

#define BITS_PER_BYTE 10u /* start, 8 data, stop */
#define BAUD_CLOCK_HZ 2000000u
#define BAUD_TOLERANCE_PERCENT 3u
#define POLL_STEP_MS 50u /* finders are polled at least this often while idle */
#define PENDING_MAX (4u * HOST_BUS_MAX_SERVOS) /* replies one byte can cause (rescans included) */

typedef struct {
  size_t servo_index;
  uint64_t start_us;
  dxl_response_t response;
} pending_reply_t;

static uint32_t baud_bps(uint8_t baud_register) { return BAUD_CLOCK_HZ / ((uint32_t)baud_register + 1u); }

bool host_bus_bauds_match(uint8_t a, uint8_t b) {
  const uint64_t fa = baud_bps(a);
  const uint64_t fb = baud_bps(b);
  const uint64_t diff = fa > fb ? fa - fb : fb - fa;
  return diff * 100u <= (uint64_t)BAUD_TOLERANCE_PERCENT * (fa < fb ? fa : fb);
}

static uint64_t byte_time_us(uint8_t baud_register) {
  return ((uint64_t)BITS_PER_BYTE * 1000000u + baud_bps(baud_register) - 1u) / baud_bps(baud_register);
}

static uint16_t now_ms(const host_bus_t *bus) { return (uint16_t)(bus->now_us / 1000u); }

static void set_temperature(host_bus_t *bus, host_bus_servo_t *hs) {
  hs->servo.table[CT_ADDR_PRESENT_TEMPERATURE] = bus->temperature_c;
}

static void power_up(host_bus_t *bus, host_bus_servo_t *hs) {
  dxl_servo_power_up(&hs->servo, dxl_image_settings(hs->eeprom_image), HOST_BUS_PRESENT_POSITION);
  set_temperature(bus, hs);
  dxl_finder_init(&hs->finder);
  hs->uart_baud = hs->servo.table[CT_ADDR_BAUD_RATE];
}

void host_bus_init(host_bus_t *bus, const uint8_t *ids, size_t count, uint8_t baud, uint8_t temperature_c) {
  memset(bus, 0, sizeof *bus);
  bus->servo_count = count > HOST_BUS_MAX_SERVOS ? HOST_BUS_MAX_SERVOS : count;
  bus->master_baud = baud;
  bus->temperature_c = temperature_c;
  for (size_t i = 0; i < bus->servo_count; i++) {
    host_bus_servo_t *hs = &bus->servos[i];
    dxl_servo_power_up(&hs->servo, NULL, HOST_BUS_PRESENT_POSITION); /* factory defaults */
    hs->servo.table[CT_ADDR_ID] = ids[i];
    hs->servo.table[CT_ADDR_BAUD_RATE] = baud;
    dxl_image_build(hs->eeprom_image, hs->servo.table);
    power_up(bus, hs);
  }
  conformance_on_bus_init(bus);
}

/* The board side of the after-reply policy (dxl_after_port.h): the port is the servo. A
 * store is complete at once here (the firmware's takes milliseconds: docs/firmware.md). */
void dxl_after_port_persist(void *port, const uint8_t *table) {
  host_bus_servo_t *hs = port;
  dxl_image_build(hs->eeprom_image, table);
}

void dxl_after_port_set_baud(void *port, uint8_t baud_register) {
  host_bus_servo_t *hs = port;
  hs->uart_baud = baud_register;
}

/* What follows a reply (dxl_after.h); a factory reset also clears Present Temperature,
 * which the harness stands in for the control layer to fill. */
static void after_reply(host_bus_t *bus, host_bus_servo_t *hs, uint8_t after) {
  dxl_after_reply(&hs->servo, after, hs);
  if (after & DXL_AFTER_FACTORY_RESET) {
    set_temperature(bus, hs);
  }
}

static void deliver(host_bus_t *bus, size_t sender, uint8_t sender_baud, uint8_t byte, pending_reply_t *pending,
                    size_t *pending_count);

/* Feeds one byte to one servo and collects what it wants to send. */
static void receive(host_bus_t *bus, size_t index, uint8_t byte, pending_reply_t *pending, size_t *pending_count) {
  host_bus_servo_t *hs = &bus->servos[index];
  dxl_finder_push(&hs->finder, byte, now_ms(bus));
  hs->rx_count++;
  dxl_packet_t packet;
  dxl_find_result_t found;
  while ((found = dxl_finder_next(&hs->finder, &packet)) != DXL_FIND_NONE) {
    /* The packet is bytes[0 .. 4 + LENGTH) of the finder, the newest byte its fill-1. */
    const size_t length = 4u + hs->finder.bytes[3];
    uint8_t framed[DXL_PACKET_MAX_BYTES];
    memcpy(framed, hs->finder.bytes, length);
    const uint64_t first_rx_index = hs->rx_count - hs->finder.fill;

    dxl_response_t response;
    if (found == DXL_FIND_PACKET) {
      hs->packets++;
      dxl_servo_handle(&hs->servo, &packet, &response);
    } else {
      hs->bad_checksums++;
      dxl_servo_reject_checksum(&hs->servo, &packet, &response);
    }
    dxl_after_commit(&hs->servo, response.after, hs); /* dxl_servo_handle committed */
    if (bus->observer != NULL) {
      const host_bus_event_t event = {index, found, first_rx_index, framed, length, &response};
      bus->observer(bus->observer_context, bus, &event);
    }
    if (response.length == 0 || *pending_count == PENDING_MAX) {
      after_reply(bus, hs, response.after);
    } else {
      pending_reply_t *p = &pending[(*pending_count)++];
      p->servo_index = index;
      p->start_us = bus->now_us + response.delay_us;
      p->response = response;
    }
  }
}

/* Transmits the collected replies, earliest start first; each reply's bytes reach the master
 * and the other servos (whose own replies, if any, follow in the same way). */
static void transmit_replies(host_bus_t *bus, pending_reply_t *pending, size_t pending_count) {
  bool sent[PENDING_MAX] = {false};
  uint64_t bus_free_us = 0;
  for (size_t n = 0; n < pending_count; n++) {
    size_t next = pending_count;
    for (size_t i = 0; i < pending_count; i++) {
      if (!sent[i] && (next == pending_count || pending[i].start_us < pending[next].start_us)) {
        next = i;
      }
    }
    sent[next] = true;
    pending_reply_t *r = &pending[next];
    host_bus_servo_t *hs = &bus->servos[r->servo_index];
    if (n > 0 && r->start_us < bus_free_us) {
      bus->collision = true;
    }
    if (r->start_us > bus->now_us) {
      bus->now_us = r->start_us;
    }
    for (uint8_t i = 0; i < r->response.length; i++) {
      pending_reply_t echo_pending[PENDING_MAX];
      size_t echo_count = 0;
      bus->now_us += byte_time_us(hs->uart_baud);
      deliver(bus, r->servo_index, hs->uart_baud, r->response.bytes[i], echo_pending, &echo_count);
      /* A status packet is never an instruction for the others (their IDs differ), but
       * should one answer, it is transmitted after this reply. */
      if (echo_count != 0) {
        transmit_replies(bus, echo_pending, echo_count);
      }
    }
    bus_free_us = bus->now_us;
    after_reply(bus, hs, r->response.after);
  }
}

/* One byte on the wire from sender (SIZE_MAX: the master) at sender_baud. */
static void deliver(host_bus_t *bus, size_t sender, uint8_t sender_baud, uint8_t byte, pending_reply_t *pending,
                    size_t *pending_count) {
  if (sender != SIZE_MAX && host_bus_bauds_match(sender_baud, bus->master_baud) &&
      bus->heard_len < HOST_BUS_HEARD_MAX) {
    bus->heard[bus->heard_len++] = byte;
  }
  for (size_t i = 0; i < bus->servo_count; i++) {
    if (i != sender && host_bus_bauds_match(sender_baud, bus->servos[i].uart_baud)) {
      receive(bus, i, byte, pending, pending_count);
    }
  }
}

void host_bus_send_more(host_bus_t *bus, const uint8_t *bytes, size_t length) {
  const size_t heard_from = bus->heard_len;
  conformance_on_send_begin(bus);
  for (size_t i = 0; i < length; i++) {
    pending_reply_t pending[PENDING_MAX];
    size_t pending_count = 0;
    bus->now_us += byte_time_us(bus->master_baud);
    deliver(bus, SIZE_MAX, bus->master_baud, bytes[i], pending, &pending_count);
    transmit_replies(bus, pending, pending_count);
  }
  conformance_on_send_end(bus, bytes, length, heard_from);
}

void host_bus_send(host_bus_t *bus, const uint8_t *bytes, size_t length) {
  bus->heard_len = 0;
  bus->collision = false;
  host_bus_send_more(bus, bytes, length);
}

void host_bus_wait_ms(host_bus_t *bus, uint32_t ms) {
  while (ms > 0) {
    const uint32_t step = ms < POLL_STEP_MS ? ms : POLL_STEP_MS;
    bus->now_us += (uint64_t)step * 1000u;
    ms -= step;
    for (size_t i = 0; i < bus->servo_count; i++) {
      dxl_finder_poll(&bus->servos[i].finder, now_ms(bus));
    }
  }
}

void host_bus_set_master_baud(host_bus_t *bus, uint8_t baud_register) {
  bus->master_baud = baud_register;
  conformance_on_master_baud(bus, baud_register);
}

void host_bus_power_cycle(host_bus_t *bus) {
  for (size_t i = 0; i < bus->servo_count; i++) {
    power_up(bus, &bus->servos[i]);
  }
  conformance_on_power_cycle(bus);
}

host_bus_servo_t *host_bus_find(host_bus_t *bus, uint8_t id) {
  for (size_t i = 0; i < bus->servo_count; i++) {
    if (bus->servos[i].servo.table[CT_ADDR_ID] == id) {
      return &bus->servos[i];
    }
  }
  return NULL;
}
