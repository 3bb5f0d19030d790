/* A fake UART for the link layer on the host: the board functions of dxl_link_port.h and
 * dxl_after_port.h, with port = a fake_uart_t. Cycle-free but order-exact: a byte is in the
 * ring when fake_uart_receive() returns; a reply starts when the link says so and is on the
 * wire until the caller ends it (fake_uart_reply_sent); each board function the link calls is
 * written to the event log in the order of the calls.
 *
 * The sniff is off (DXL_LINK_SNIFF_OFF) unless sniff_enabled: then dxl_link_port_sniff_start
 * sets it waiting, and the caller plays the RX interrupt (fake_uart_arm, fake_uart_checksum,
 * fake_uart_sniff_*): the fake frames nothing itself.
 *
 * Time: now_us, set by the caller; a byte is stamped with it on arrival, and a reply started
 * by dxl_link_port_reply_start() is due delay_us after the newest byte when the ring is empty
 * (the packet's last byte), at once otherwise (as the firmware's uart_reply_start). */
#ifndef FAKE_UART_H
#define FAKE_UART_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "dxl_table.h"
#include "dxl_link.h"

#define FAKE_UART_LOG_BYTES 2048u

typedef struct fake_uart fake_uart_t;

struct fake_uart {
  uint64_t now_us;
  /* Receive ring: 256 slots, 8-bit free-running indices as the firmware's. */
  uint8_t ring[256];
  uint8_t head;
  uint8_t tail;
  uint64_t taken_count;   /* bytes the link has taken since fake_uart_init */
  uint64_t newest_rx_us;  /* arrival of the newest byte */
  /* The reply. */
  uint8_t reply_state;    /* DXL_LINK_REPLY_* */
  const uint8_t *reply_bytes;
  uint8_t reply_length;
  uint8_t reply_published;
  uint16_t reply_delay_us;
  uint64_t reply_start_us; /* when the reply is due (WAITING / SENDING) */
  unsigned reply_load_count; /* dxl_link_port_reply_load calls since fake_uart_init */
  /* The sniff, played by the caller when sniff_enabled. */
  bool sniff_enabled;
  uint8_t sniff;
  uint8_t sniff_end;
  uint8_t skip;           /* bytes of another servo's packet still to skip (fake_uart_sniff_skip) */
  bool woken;             /* dxl_link_port_wake since the caller cleared it */
  /* The board. */
  uint8_t baud_register;  /* the last dxl_after_port_set_baud */
  uint8_t stored[CT_EEPROM_SIZE]; /* the last table stored */
  unsigned store_count;
  char log[FAKE_UART_LOG_BYTES];
  bool log_full;
  /* Optional hooks: bytes the link takes from the ring (count may be 0: an empty batch), a
   * store and a new baud (each after it is recorded), a packet handled. */
  void (*on_take)(void *context, const uint8_t *bytes, uint8_t count);
  void (*on_store)(void *context, const uint8_t *table);
  void (*on_baud)(void *context, uint8_t baud_register);
  void (*on_handled)(void *context, dxl_find_result_t found, const uint8_t *bytes, uint16_t length,
                     const dxl_response_t *response);
  void *context;
};

void fake_uart_init(fake_uart_t *uart, uint8_t baud_register);

/* A byte arrives (stamped now_us); false when the ring is full (the byte is lost). While a
 * skip is under way (fake_uart_sniff_skip) the byte is counted down and forgotten instead, not
 * stamped, as the RX interrupt does. */
bool fake_uart_receive(fake_uart_t *uart, uint8_t byte);

/* The reply on the wire has left (SENDING or WAITING -> DONE). */
void fake_uart_reply_sent(fake_uart_t *uart);

/* As the RX interrupt's sniff at a packet's last byte but one, for a packet of this servo
 * whose checksum comes next: arms the loaded reply (a PING's ready reply; anything else
 * streams its first DXL_STREAM_HEADER_BYTES); the packet ends one byte after the ring's head. */
void fake_uart_arm(fake_uart_t *uart, bool ping);

/* As the RX interrupt at the armed packet's checksum: the byte goes into the ring and the
 * reply starts (matched) or is dropped (IDLE). */
void fake_uart_checksum(fake_uart_t *uart, uint8_t byte, bool matched);

/* As the sniff at a header byte before the LENGTH (FF, FF, ID): it holds the byte in its state
 * (WAITING -> 1 -> 2 -> DXL_LINK_SNIFF_LENGTH), not in the ring. */
void fake_uart_sniff_header(fake_uart_t *uart);

/* As the sniff at the LENGTH of another servo's packet: the RX interrupt skips the length bytes
 * that follow (fake_uart_receive), and the sniff waits for the next packet's first byte. */
void fake_uart_sniff_skip(fake_uart_t *uart, uint8_t length);

/* As the sniff at the LENGTH of a packet it keeps and does not arm (broadcast, or this servo's
 * with an instruction it does not arm): header[0..4) = FF FF ID LENGTH goes into the ring, and
 * the sniff holds the bytes that follow there, the link leaving them alone, until
 * fake_uart_sniff_hand_over. */
void fake_uart_sniff_keep(fake_uart_t *uart, const uint8_t *header);

/* As the RX interrupt at the checksum of a packet the sniff kept and did not arm: the byte goes
 * into the ring and the sniff ends (OFF); the whole packet is the finder's. */
void fake_uart_sniff_hand_over(fake_uart_t *uart, uint8_t checksum);

/* The bytes of the reply the UART can send so far: reply_bytes[0..published). */
static inline uint8_t fake_uart_reply_ready(const fake_uart_t *uart) { return uart->reply_published; }

/* Appends text to the event log. */
void fake_uart_log(fake_uart_t *uart, const char *text);

#endif
