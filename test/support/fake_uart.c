#include "fake_uart.h"

#include <stdio.h>
#include <string.h>

#include "dxl_after_port.h"
#include "dxl_link_port.h"
#include "dxl_protocol.h"
#include "dxl_servo.h"

void fake_uart_init(fake_uart_t *uart, uint8_t baud_register) {
  memset(uart, 0, sizeof *uart);
  uart->baud_register = baud_register;
  for (unsigned i = 0; i < FAKE_UART_STARTS; i++) {
    uart->starts[i].pushed_at = UINT64_MAX;
  }
}

void fake_uart_log(fake_uart_t *uart, const char *text) {
  const size_t used = strlen(uart->log);
  if (used + strlen(text) + 1u > sizeof uart->log) {
    uart->log_full = true;
    return;
  }
  memcpy(uart->log + used, text, strlen(text) + 1u);
}

static bool ring_put(fake_uart_t *uart, uint8_t byte) {
  if ((uint8_t)(uart->head - uart->tail) == 0xFFu) {
    return false;
  }
  uart->ring[uart->head++] = byte;
  uart->pushed_count++;
  return true;
}

uint64_t fake_uart_wire_index(const fake_uart_t *uart, uint64_t pushed_at) {
  for (unsigned i = 0; i < FAKE_UART_STARTS; i++) {
    if (uart->starts[i].pushed_at == pushed_at) {
      return uart->starts[i].received_at;
    }
  }
  return UINT64_MAX;
}

/* The gap rule at now_us: more than DXL_PACKET_GAP_TIMEOUT_MS since the last byte ends the
 * header, packet or skip under way (an armed reply goes back to IDLE). */
static void gap_check(fake_uart_t *uart) {
  const bool under_way = uart->frame.state != DXL_FRAME_SEARCH || uart->skip != 0;
  if (!under_way || !dxl_frame_gap((uint16_t)(uart->last_byte_us / 1000u), (uint16_t)(uart->now_us / 1000u))) {
    return;
  }
  dxl_frame_reset(&uart->frame);
  uart->skip = 0;
  if (uart->rx_armed) {
    uart->rx_armed = false;
    uart->armed_published = false;
    if (uart->reply_state == DXL_LINK_REPLY_ARMED) {
      uart->reply_state = DXL_LINK_REPLY_IDLE;
    }
  }
  uart->gap_cut = true;
  uart->gap_cut_at = uart->head;
}

static bool at_gap(const fake_uart_t *uart) { return uart->gap_cut && uart->tail == uart->gap_cut_at; }

bool fake_uart_receive(fake_uart_t *uart, uint8_t byte) {
  gap_check(uart);
  uart->last_byte_us = uart->now_us;
  const uint64_t index = uart->received_count++;
  if (uart->skip != 0) {
    uart->skip--;
    return true;
  }
  const uint8_t event = dxl_frame_step(&uart->frame, byte);
  if (event == DXL_BYTE_HEADER && uart->frame.state == DXL_FRAME_LENGTH) {
    uart->id_at = index;
  }
  switch (event) {
  case DXL_BYTE_LENGTH: {
    const uint8_t id = uart->frame.id;
    if (uart->listening && id != uart->listen_id && id != DXL_ID_BROADCAST) {
      uart->skip = uart->frame.length; /* another servo's: passed over */
      dxl_frame_reset(&uart->frame);
      return true;
    }
    uart->listening = false; /* kept: what follows waits for the link */
    uart->starts[uart->starts_next].pushed_at = uart->pushed_count;
    uart->starts[uart->starts_next].received_at = uart->id_at - 2u;
    uart->starts_next = (uart->starts_next + 1u) % FAKE_UART_STARTS;
    bool kept = ring_put(uart, DXL_HEADER_BYTE);
    kept &= ring_put(uart, DXL_HEADER_BYTE);
    kept &= ring_put(uart, id);
    kept &= ring_put(uart, uart->frame.length);
    return kept;
  }
  case DXL_BYTE_BODY:
    return ring_put(uart, byte);
  case DXL_BYTE_CHECKSUM:
  case DXL_BYTE_CHECKSUM_BAD:
    uart->newest_end_us = uart->now_us;
    return ring_put(uart, byte);
  default: /* garbage, a header's byte, a Protocol 2.0 frame's */
    return true;
  }
}

void fake_uart_reply_sent(fake_uart_t *uart) {
  uart->reply_state = DXL_LINK_REPLY_DONE;
  fake_uart_log(uart, "sent ");
}

void fake_uart_arm(fake_uart_t *uart, bool ping) {
  uart->rx_armed = true;
  uart->armed_end = (uint8_t)(uart->head + 1u);
  uart->reply_state = DXL_LINK_REPLY_ARMED;
  if (!ping) {
    uart->reply_published = DXL_STREAM_HEADER_BYTES;
  }
  fake_uart_log(uart, "armed ");
}

void fake_uart_checksum(fake_uart_t *uart, uint8_t byte, bool matched) {
  (void)fake_uart_receive(uart, byte);
  if (uart->reply_state != DXL_LINK_REPLY_ARMED) {
    return;
  }
  if (matched) {
    uart->reply_state = DXL_LINK_REPLY_SENDING;
    uart->reply_start_us = uart->now_us + uart->reply_delay_us;
    fake_uart_log(uart, "start ");
  } else {
    uart->reply_state = DXL_LINK_REPLY_IDLE;
  }
}

static void reply_load(fake_uart_t *uart, const uint8_t *bytes, uint8_t length, uint16_t delay_us) {
  uart->reply_bytes = bytes;
  uart->reply_length = length;
  uart->reply_published = length;
  uart->reply_delay_us = delay_us;
  uart->reply_load_count++;
}

/* dxl_link_port.h */

uint8_t dxl_link_port_state(void *port) {
  fake_uart_t *uart = port;
  uint8_t state = uart->reply_state;
  if (uart->head != uart->tail) {
    state |= DXL_LINK_RX_BYTES;
  }
  if (at_gap(uart)) {
    state |= DXL_LINK_RX_GAP;
  }
  if (uart->rx_armed) {
    state |= DXL_LINK_RX_ARMED;
  }
  if (dxl_frame_in_packet(uart->frame.state)) {
    state |= DXL_LINK_RX_BUSY;
  }
  return state;
}

uint8_t dxl_link_port_rx_take(void *port, uint8_t *dst, uint8_t max) {
  fake_uart_t *uart = port;
  if (at_gap(uart)) {
    uart->gap_cut = false; /* the link has dropped the packet the gap ended */
  }
  uint8_t count = (uint8_t)((uart->gap_cut ? uart->gap_cut_at : uart->head) - uart->tail);
  if (uart->rx_armed && !uart->armed_published) {
    count = (uint8_t)(uart->armed_end - 1u - uart->tail); /* up to its checksum, which waits */
  }
  if (count > max) {
    count = max;
  }
  for (uint8_t i = 0; i < count; i++) {
    dst[i] = uart->ring[uart->tail++];
  }
  uart->taken_count += count;
  if (uart->rx_armed && uart->tail == uart->armed_end) {
    uart->rx_armed = false;
    uart->armed_published = false;
  }
  return count;
}

void dxl_link_port_rx_tick(void *port) { gap_check(port); }

bool dxl_link_port_listen(void *port, const uint8_t *ping_reply, uint16_t delay_us, uint8_t id, uint8_t mask) {
  fake_uart_t *uart = port;
  if (uart->reply_state != DXL_LINK_REPLY_IDLE || uart->head != uart->tail) {
    return false;
  }
  reply_load(uart, ping_reply, DXL_PING_REPLY_BYTES, delay_us);
  uart->listening = true;
  uart->listen_id = id;
  uart->listen_mask = mask;
  return true;
}

void dxl_link_port_reply_send(void *port, const uint8_t *bytes, uint8_t length, uint16_t delay_us) {
  fake_uart_t *uart = port;
  reply_load(uart, bytes, length, delay_us);
  const uint64_t due = uart->newest_end_us + uart->reply_delay_us;
  uart->reply_start_us = (uart->head == uart->tail && due > uart->now_us) ? due : uart->now_us;
  uart->reply_state = DXL_LINK_REPLY_SENDING;
  char text[32];
  snprintf(text, sizeof text, "reply+%u ", (unsigned)(uart->reply_start_us - uart->now_us));
  fake_uart_log(uart, text);
}

void dxl_link_port_reply_publish(void *port, uint8_t length) {
  fake_uart_t *uart = port;
  uart->reply_length = length;
  uart->reply_published = length;
  uart->armed_published = uart->rx_armed;
}

void dxl_link_port_reply_finish(void *port) { ((fake_uart_t *)port)->reply_state = DXL_LINK_REPLY_IDLE; }

void dxl_link_port_handled(void *port, dxl_find_result_t found, const uint8_t *bytes, uint16_t length,
                           const dxl_response_t *response) {
  fake_uart_t *uart = port;
  if (uart->on_handled != NULL) {
    uart->on_handled(uart->context, found, bytes, length, response);
  }
}

/* dxl_after_port.h */

void dxl_after_port_persist(void *port, const uint8_t *table) {
  fake_uart_t *uart = port;
  memcpy(uart->stored, table, sizeof uart->stored);
  uart->store_count++;
  fake_uart_log(uart, "store ");
  if (uart->on_store != NULL) {
    uart->on_store(uart->context, table);
  }
}

void dxl_after_port_set_baud(void *port, uint8_t baud_register) {
  fake_uart_t *uart = port;
  uart->baud_register = baud_register;
  char text[16];
  snprintf(text, sizeof text, "baud=%u ", baud_register);
  fake_uart_log(uart, text);
  if (uart->on_baud != NULL) {
    uart->on_baud(uart->context, baud_register);
  }
}

#if DXL_HAS_BOOTLOADER
void dxl_after_port_enter_bootloader(void *port) {
  fake_uart_log(port, "bootloader ");
}
#endif
