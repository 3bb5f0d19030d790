/* The board side of the link layer (firmware/link/dxl_link_port.h, dxl_after_port.h) over
 * USART0 (hal/uart.h), the settings' store (hal/nvm.h) and the millisecond clock. One servo:
 * port is NULL and unused. Each function is a few instructions, inlined at link time. */
#include <util/atomic.h>

#include "board.h"
#include "dxl_after_port.h"
#include "dxl_link_port.h"
#include "motor.h"
#include "nvm.h"
#include "timebase.h"
#include "uart.h"
#if DXL_HAS_BOOTLOADER
#include "boot_request.h"
#include "dxl_servo.h"

extern dxl_servo_t servo; /* main.c: the one servo, whose table the store takes */
#endif

_Static_assert(DXL_LINK_REPLY_IDLE == UART_REPLY_IDLE && DXL_LINK_REPLY_ARMED == UART_REPLY_ARMED &&
                   DXL_LINK_REPLY_WAITING == UART_REPLY_WAITING && DXL_LINK_REPLY_SENDING == UART_REPLY_SENDING &&
                   DXL_LINK_REPLY_DONE == UART_REPLY_DONE,
               "the link's reply states are the UART's");
_Static_assert(DXL_LINK_SNIFF_LENGTH == UART_SNIFF_LENGTH && DXL_LINK_SNIFF_ARMED == UART_SNIFF_ARMED &&
                   DXL_LINK_SNIFF_OFF == UART_SNIFF_OFF && DXL_LINK_SNIFF_WAITING == 0,
               "the link's sniff states are the RX interrupt's");

uint8_t dxl_link_port_rx_head(void *port) {
  (void)port;
  return uart_rx_head;
}

uint8_t dxl_link_port_rx_tail(void *port) {
  (void)port;
  return uart_rx_tail;
}

void dxl_link_port_rx_take(void *port, uint8_t *dst, uint8_t count) {
  (void)port;
  uint8_t tail = uart_rx_tail;
  for (; count != 0; count--) {
    *dst++ = uart_rx_ring[tail++ & UART_RX_RING_MASK];
  }
  uart_rx_tail = tail;
}

uint8_t dxl_link_port_sniff_state(void *port) {
  (void)port;
  return uart_sniff;
}

void dxl_link_port_sniff_start(void *port, uint8_t id, uint8_t mask) {
  (void)port;
  uart_sniff_start(id, mask);
}

void dxl_link_port_sniff_adopt(void *port) {
  (void)port;
  uart_sniff = UART_SNIFF_OFF; /* ARMED: the RX interrupt no longer writes it */
}

void dxl_link_port_sniff_stop_part_way(void *port) {
  (void)port;
  uart_sniff_stop_part_way();
}

void dxl_link_port_sniff_restart_if(void *port, uint8_t state) {
  (void)port;
  ATOMIC_BLOCK(ATOMIC_FORCEON) {
    if (uart_sniff == state) {
      uart_sniff = 0;
    }
  }
}

uint8_t dxl_link_port_sniff_end(void *port) {
  (void)port;
  return uart_sniff_end;
}

uint8_t dxl_link_port_skip_count(void *port) {
  (void)port;
  return uart_skip_count;
}

void dxl_link_port_skip_end(void *port) {
  (void)port;
  uart_skip_count = 0; /* one store: the RX interrupt's decrement cannot tear it */
}

void dxl_link_port_reply_load(void *port, const uint8_t *bytes, uint8_t length, uint16_t delay_us) {
  (void)port;
  uart_reply_load(bytes, length, delay_us);
}

void dxl_link_port_reply_start(void *port) {
  (void)port;
  uart_reply_start();
}

void dxl_link_port_reply_publish(void *port, uint8_t length) {
  (void)port;
  uart_reply_publish(length);
}

bool dxl_link_port_reply_disarm(void *port) {
  (void)port;
  return uart_reply_disarm();
}

uint8_t dxl_link_port_reply_state(void *port) {
  (void)port;
  return uart_reply_state();
}

void dxl_link_port_reply_finish(void *port) {
  (void)port;
  uart_reply_finish();
}

uint16_t dxl_link_port_now_ms(void *port) {
  (void)port;
  return timebase_ms();
}

void dxl_link_port_wake(void *port) {
  (void)port;
  board_wake_set();
}

void dxl_link_port_handled(void *port, dxl_find_result_t found, const uint8_t *bytes, uint16_t length,
                           const dxl_response_t *response) {
  (void)port;
  (void)found;
  (void)bytes;
  (void)length;
  (void)response;
}

void dxl_after_port_persist(void *port, const uint8_t *table) {
  (void)port;
  (void)table; /* always servo.table, which the main loop gives nvm_service() */
  nvm_persist();
}

void dxl_after_port_set_baud(void *port, uint8_t baud_register) {
  (void)port;
  uart_set_baud(baud_register);
}

#if DXL_HAS_BOOTLOADER
/* Only with no store of the settings under way (a few bytes of 3.4 ms each), so that the
 * bootloader finds them whole and none is cut; otherwise the application stays, and the
 * flasher asks again (docs/bootloader.md "Entering from the application"). The bootloader
 * stops the motor. */
void dxl_after_port_enter_bootloader(void *port) {
  (void)port;
  if (!nvm_busy()) {
    boot_request_enter();
  }
}
#endif
