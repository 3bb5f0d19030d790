#include "host_bus.h"

#include <string.h>

#include "conformance_log.h"
#include "dxl_link_port.h"
#include "dxl_protocol.h"

#define BITS_PER_BYTE 10u /* start, 8 data, stop */
#define BAUD_CLOCK_HZ 2000000u
#define BAUD_TOLERANCE_PERCENT 3u
#define POLL_STEP_MS 50u /* the links tick at least this often while idle */
#define PENDING_MAX (4u * HOST_BUS_MAX_SERVOS) /* replies one byte can cause */

typedef struct {
  size_t servo_index;
  uint64_t start_us;
  uint8_t bytes[DXL_REPLY_MAX_BYTES];
  uint8_t length;
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

static void set_temperature(host_bus_t *bus, host_bus_servo_t *hs) {
  hs->servo.table[CT_ADDR_PRESENT_TEMPERATURE] = bus->temperature_c;
}

/* The board side of the link (fake_uart.h hooks): a store rebuilds the EEPROM image at once
 * (the firmware's takes milliseconds: docs/firmware.md); a handled packet is counted and shown
 * to the observer. */
static void on_store(void *context, const uint8_t *table) {
  host_bus_servo_t *hs = context;
  dxl_image_build(hs->eeprom_image, table);
}

static void on_handled(void *context, dxl_find_result_t found, const uint8_t *bytes, uint16_t length,
                       const dxl_response_t *response) {
  host_bus_servo_t *hs = context;
  host_bus_t *bus = hs->bus;
  if (found == DXL_FIND_PACKET) {
    hs->packets++;
  } else {
    hs->bad_checksums++;
  }
  if (bus->observer != NULL) {
    const host_bus_event_t event = {hs->index, found,
                                    fake_uart_wire_index(&hs->uart, hs->uart.taken_count - hs->link.finder.fill), bytes, length,
                                    response};
    bus->observer(bus->observer_context, bus, &event);
  }
}

/* Points a servo's link, UART and hooks at the servo itself (at power-up, before its link
 * starts, or after a copy). */
static void wire(host_bus_t *bus, host_bus_servo_t *hs, size_t index) {
  hs->bus = bus;
  hs->index = index;
  hs->uart.on_store = on_store;
  hs->uart.on_handled = on_handled;
  hs->uart.context = hs;
  hs->link.port = &hs->uart;
  if (hs->uart.reply_bytes != NULL) { /* the link's response: the reply it loaded */
    hs->uart.reply_bytes = hs->link.response.bytes;
  }
}

static void power_up(host_bus_t *bus, host_bus_servo_t *hs) {
  dxl_servo_power_up(&hs->servo, dxl_image_settings(hs->eeprom_image), HOST_BUS_PRESENT_POSITION);
  set_temperature(bus, hs);
  fake_uart_init(&hs->uart, hs->servo.table[CT_ADDR_BAUD_RATE]);
  hs->uart.now_us = bus->now_us;
  wire(bus, hs, hs->index);
  dxl_link_init(&hs->link, &hs->servo, &hs->uart);
}

void host_bus_init(host_bus_t *bus, const uint8_t *ids, size_t count, uint8_t baud, uint8_t temperature_c) {
  memset(bus, 0, sizeof *bus);
  bus->servo_count = count > HOST_BUS_MAX_SERVOS ? HOST_BUS_MAX_SERVOS : count;
  bus->master_baud = baud;
  bus->temperature_c = temperature_c;
  for (size_t i = 0; i < bus->servo_count; i++) {
    host_bus_servo_t *hs = &bus->servos[i];
    hs->index = i;
    dxl_servo_power_up(&hs->servo, NULL, HOST_BUS_PRESENT_POSITION); /* factory defaults */
    hs->servo.table[CT_ADDR_ID] = ids[i];
    hs->servo.table[CT_ADDR_BAUD_RATE] = baud;
    dxl_image_build(hs->eeprom_image, hs->servo.table);
    power_up(bus, hs);
  }
  conformance_on_bus_init(bus);
}

void host_bus_copy(host_bus_t *dst, const host_bus_t *src) {
  memcpy(dst, src, sizeof *dst);
  for (size_t i = 0; i < dst->servo_count; i++) {
    wire(dst, &dst->servos[i], i);
  }
}

/* The link takes what waits in the servo's ring (as the firmware's main loop passes do), and
 * a reply it starts is collected. Present Temperature, which a factory reset clears, is the
 * harness's to fill (the control layer's on the firmware). */
static void service(host_bus_t *bus, host_bus_servo_t *hs, pending_reply_t *pending, size_t *pending_count) {
  hs->uart.now_us = bus->now_us;
  while (dxl_link_service_rx(&hs->link, &hs->servo)) {
  }
  set_temperature(bus, hs);
  if (hs->uart.reply_state == DXL_LINK_REPLY_SENDING && *pending_count < PENDING_MAX) {
    pending_reply_t *p = &pending[(*pending_count)++];
    p->servo_index = hs->index;
    p->start_us = hs->uart.reply_start_us;
    p->length = hs->uart.reply_length;
    memcpy(p->bytes, hs->uart.reply_bytes, p->length);
    hs->uart.reply_state = DXL_LINK_REPLY_WAITING; /* collected: on the wire until sent */
  }
}

static void deliver(host_bus_t *bus, size_t sender, uint8_t sender_baud, uint8_t byte, pending_reply_t *pending,
                    size_t *pending_count);

/* Transmits the collected replies, earliest start first; each reply's bytes reach the master
 * and the other servos (whose own replies, if any, follow in the same way). Once a servo's
 * reply has left, its link applies what follows it and takes what waited meanwhile. */
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
    for (uint8_t i = 0; i < r->length; i++) {
      pending_reply_t echo_pending[PENDING_MAX];
      size_t echo_count = 0;
      bus->now_us += byte_time_us(hs->uart.baud_register);
      deliver(bus, r->servo_index, hs->uart.baud_register, r->bytes[i], echo_pending, &echo_count);
      /* A status packet is never an instruction for the others (their IDs differ), but
       * should one answer, it is transmitted after this reply. */
      if (echo_count != 0) {
        transmit_replies(bus, echo_pending, echo_count);
      }
    }
    bus_free_us = bus->now_us;
    fake_uart_reply_sent(&hs->uart);
    hs->uart.now_us = bus->now_us;
    dxl_link_service_reply(&hs->link, &hs->servo);
    pending_reply_t more[PENDING_MAX];
    size_t more_count = 0;
    service(bus, hs, more, &more_count);
    if (more_count != 0) {
      transmit_replies(bus, more, more_count);
    }
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
    host_bus_servo_t *hs = &bus->servos[i];
    if (i != sender && host_bus_bauds_match(sender_baud, hs->uart.baud_register)) {
      hs->uart.now_us = bus->now_us;
      (void)fake_uart_receive(&hs->uart, byte);
      service(bus, hs, pending, pending_count);
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
      host_bus_servo_t *hs = &bus->servos[i];
      pending_reply_t pending[PENDING_MAX];
      size_t pending_count = 0;
      hs->uart.now_us = bus->now_us;
      dxl_link_tick(&hs->link);
      service(bus, hs, pending, &pending_count);
      transmit_replies(bus, pending, pending_count);
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
