/* The board side of the link layer's seam (link/dxl_link_port.h, link/dxl_after_port.h): the
 * receive ring, the reply and listening over USART0 (uart.h), the settings' store (nvm.h), the
 * bootloader's entry. One servo: port is NULL and unused. Each function is a few instructions,
 * inlined at link time. */
#include "dxl_after_port.h"
#include "dxl_link_port.h"
#include "nvm.h"
#include "uart.h"
#if DXL_HAS_BOOTLOADER
#include "boot_request.h"
#endif

_Static_assert(DXL_LINK_REPLY_IDLE == UART_REPLY_IDLE && DXL_LINK_REPLY_ARMED == UART_REPLY_ARMED &&
                   DXL_LINK_REPLY_WAITING == UART_REPLY_WAITING && DXL_LINK_REPLY_SENDING == UART_REPLY_SENDING &&
                   DXL_LINK_REPLY_DONE == UART_REPLY_DONE && (UART_REPLY_DONE & ~DXL_LINK_REPLY_MASK) == 0,
               "the link's reply states are the UART's");

uint8_t dxl_link_port_state(void *port) {
  (void)port;
  uint8_t state = uart_reply_state();
  if (uart_rx_head != uart_rx_tail) {
    state |= DXL_LINK_RX_BYTES;
  }
  if (uart_rx_at_gap()) {
    state |= DXL_LINK_RX_GAP;
  }
  if (uart_rx_armed != UART_RX_ARMED_NONE) {
    state |= DXL_LINK_RX_ARMED;
  }
  if (dxl_frame_in_packet(uart_rx_progress[UART_RX_OFS_FRAME + DXL_FRAME_OFS_STATE])) {
    state |= DXL_LINK_RX_BUSY;
  }
  return state;
}

uint8_t dxl_link_port_rx_take(void *port, uint8_t *dst, uint8_t max) {
  (void)port;
  return uart_rx_take(dst, max);
}

void dxl_link_port_rx_tick(void *port) {
  (void)port;
  uart_rx_gap_ms();
}

bool dxl_link_port_listen(void *port, const uint8_t *ping_reply, uint16_t delay_us, uint8_t id, uint8_t mask) {
  (void)port;
  return uart_listen(ping_reply, delay_us, id, mask);
}

void dxl_link_port_reply_send(void *port, const uint8_t *bytes, uint8_t length, uint16_t delay_us) {
  (void)port;
  uart_reply_send(bytes, length, delay_us);
}

void dxl_link_port_reply_publish(void *port, uint8_t length) {
  (void)port;
  uart_reply_publish(length);
}

void dxl_link_port_reply_finish(void *port) {
  (void)port;
  uart_reply_finish();
}

void dxl_after_port_persist(void *port, const uint8_t *table) {
  (void)port;
  (void)table; /* the servo's table, which the main loop gives nvm_service() */
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
