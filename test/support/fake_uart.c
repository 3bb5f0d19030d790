#include "fake_uart.h"

#include <stdio.h>
#include <string.h>

#include "dxl_after_port.h"
#include "dxl_link_port.h"
#include "dxl_servo.h"

void fake_uart_init(fake_uart_t *uart, uint8_t baud_register) {
  memset(uart, 0, sizeof *uart);
  uart->baud_register = baud_register;
  uart->sniff = DXL_LINK_SNIFF_OFF;
}

void fake_uart_log(fake_uart_t *uart, const char *text) {
  const size_t used = strlen(uart->log);
  if (used + strlen(text) + 1u > sizeof uart->log) {
    uart->log_full = true;
    return;
  }
  memcpy(uart->log + used, text, strlen(text) + 1u);
}

bool fake_uart_receive(fake_uart_t *uart, uint8_t byte) {
  if (uart->skip != 0) {
    uart->skip--;
    return true;
  }
  if ((uint8_t)(uart->head - uart->tail) == 0xFFu) {
    return false;
  }
  uart->ring[uart->head++] = byte;
  uart->newest_rx_us = uart->now_us;
  return true;
}

void fake_uart_reply_sent(fake_uart_t *uart) {
  uart->reply_state = DXL_LINK_REPLY_DONE;
  fake_uart_log(uart, "sent ");
}

void fake_uart_arm(fake_uart_t *uart, bool ping) {
  uart->sniff = DXL_LINK_SNIFF_ARMED;
  uart->sniff_end = (uint8_t)(uart->head + 1u);
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

void fake_uart_sniff_header(fake_uart_t *uart) { uart->sniff++; }

void fake_uart_sniff_skip(fake_uart_t *uart, uint8_t length) {
  uart->skip = length;
  uart->sniff = DXL_LINK_SNIFF_WAITING;
}

#define HEADER_BYTES 4u /* FF FF ID LENGTH */

void fake_uart_sniff_keep(fake_uart_t *uart, const uint8_t *header) {
  for (uint8_t i = 0; i < HEADER_BYTES; i++) {
    (void)fake_uart_receive(uart, header[i]);
  }
  uart->sniff = DXL_LINK_SNIFF_LENGTH + 1u; /* past the header, holding the packet */
}

void fake_uart_sniff_hand_over(fake_uart_t *uart, uint8_t checksum) {
  (void)fake_uart_receive(uart, checksum);
  uart->sniff = DXL_LINK_SNIFF_OFF;
}

/* dxl_link_port.h */

uint8_t dxl_link_port_rx_head(void *port) { return ((fake_uart_t *)port)->head; }

uint8_t dxl_link_port_rx_tail(void *port) { return ((fake_uart_t *)port)->tail; }

void dxl_link_port_rx_take(void *port, uint8_t *dst, uint8_t count) {
  fake_uart_t *uart = port;
  for (uint8_t i = 0; i < count; i++) {
    dst[i] = uart->ring[uart->tail++];
  }
  uart->taken_count += count;
  if (uart->on_take != NULL) {
    uart->on_take(uart->context, dst, count);
  }
}

uint8_t dxl_link_port_sniff_state(void *port) { return ((fake_uart_t *)port)->sniff; }

void dxl_link_port_sniff_start(void *port, uint8_t id, uint8_t mask) {
  fake_uart_t *uart = port;
  (void)id;   /* the caller plays the sniff, knowing the packets it sends */
  (void)mask;
  if (uart->sniff_enabled && uart->reply_state == DXL_LINK_REPLY_IDLE && uart->head == uart->tail) {
    uart->sniff = DXL_LINK_SNIFF_WAITING;
  }
}

void dxl_link_port_sniff_adopt(void *port) { ((fake_uart_t *)port)->sniff = DXL_LINK_SNIFF_OFF; }

void dxl_link_port_sniff_stop_part_way(void *port) {
  fake_uart_t *uart = port;
  if (uart->sniff < DXL_LINK_SNIFF_ARMED) {
    uart->sniff = DXL_LINK_SNIFF_OFF;
  }
}

void dxl_link_port_sniff_restart_if(void *port, uint8_t state) {
  fake_uart_t *uart = port;
  if (uart->sniff == state) {
    uart->sniff = DXL_LINK_SNIFF_WAITING;
  }
}

uint8_t dxl_link_port_sniff_end(void *port) { return ((fake_uart_t *)port)->sniff_end; }

uint8_t dxl_link_port_skip_count(void *port) { return ((fake_uart_t *)port)->skip; }

void dxl_link_port_skip_end(void *port) { ((fake_uart_t *)port)->skip = 0; }

void dxl_link_port_reply_load(void *port, const uint8_t *bytes, uint8_t length, uint16_t delay_us) {
  fake_uart_t *uart = port;
  uart->reply_bytes = bytes;
  uart->reply_length = length;
  uart->reply_published = length;
  uart->reply_delay_us = delay_us;
  uart->reply_load_count++;
}

void dxl_link_port_reply_start(void *port) {
  fake_uart_t *uart = port;
  const uint64_t due = uart->newest_rx_us + uart->reply_delay_us;
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
}

bool dxl_link_port_reply_disarm(void *port) {
  fake_uart_t *uart = port;
  if (uart->reply_state != DXL_LINK_REPLY_ARMED) {
    return false;
  }
  uart->reply_state = DXL_LINK_REPLY_IDLE;
  return true;
}

uint8_t dxl_link_port_reply_state(void *port) { return ((fake_uart_t *)port)->reply_state; }

void dxl_link_port_reply_finish(void *port) { ((fake_uart_t *)port)->reply_state = DXL_LINK_REPLY_IDLE; }

uint16_t dxl_link_port_now_ms(void *port) { return (uint16_t)(((fake_uart_t *)port)->now_us / 1000u); }

void dxl_link_port_wake(void *port) { ((fake_uart_t *)port)->woken = true; }

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
