/* A fake UART for the link layer on the host: the board functions of dxl_link_port.h and
 * dxl_after_port.h, with port = a fake_uart_t. Cycle-free but order-exact: a byte is framed
 * (and, kept, in the ring) when fake_uart_receive() returns; a reply starts when the link says
 * so and is on the wire until the caller ends it (fake_uart_reply_sent); each board function
 * the link calls is written to the event log in the order of the calls.
 *
 * The receiver is the firmware's, in C: every byte goes through the framing step
 * (dxl_frame_step), the packets kept go into the ring as FF FF ID LENGTH and their LENGTH
 * bytes, and while the link listens, another servo's packet is passed over from its LENGTH on.
 * It arms nothing by itself: the caller plays the RX interrupt's arming (fake_uart_arm,
 * fake_uart_checksum) when it wants the armed path.
 *
 * Time: now_us, set by the caller; the gap is measured on it in whole milliseconds
 * (dxl_frame_gap), at each byte's arrival and at each dxl_link_port_rx_tick, as the firmware's
 * ticks every millisecond would see it; a reply started by dxl_link_port_reply_send() is due
 * delay_us after the last kept packet's checksum when the ring is empty, at once otherwise (as
 * the firmware's uart_reply_send). */
#ifndef FAKE_UART_H
#define FAKE_UART_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "dxl_frame.h"
#include "dxl_link.h"
#include "dxl_table.h"

#define FAKE_UART_LOG_BYTES 2048u
#define FAKE_UART_STARTS 128u

typedef struct fake_uart fake_uart_t;

struct fake_uart {
  uint64_t now_us;
  /* The receiver: the framing state, a skip under way, listening. */
  dxl_frame_t frame;
  uint8_t skip;            /* bytes of a packet passed over still to come */
  bool listening;
  uint8_t listen_id;
  uint8_t listen_mask;
  uint64_t last_byte_us;   /* arrival of the newest byte, kept or not */
  bool gap_cut;            /* a gap ended a packet where the ring's gap_cut_at is */
  uint8_t gap_cut_at;
  /* Receive ring: 256 slots, 8-bit free-running indices as the firmware's. */
  uint8_t ring[256];
  uint8_t head;
  uint8_t tail;
  uint64_t taken_count;   /* bytes the link has taken since fake_uart_init */
  uint64_t received_count; /* bytes received (fake_uart_receive) since fake_uart_init */
  uint64_t pushed_count;   /* bytes put into the ring since fake_uart_init */
  uint64_t id_at;          /* received_count index of the ID of the header under way */
  /* Where the last FAKE_UART_STARTS kept packets began on the wire (the FF FF before the ID,
   * as a received_count index), by the index of their first byte among the bytes put into the
   * ring: fake_uart_wire_index. */
  struct {
    uint64_t pushed_at;
    uint64_t received_at;
  } starts[FAKE_UART_STARTS];
  unsigned starts_next;
  uint64_t newest_end_us; /* arrival of the newest kept packet's checksum */
  /* Arming, played by the caller. */
  bool rx_armed;
  bool armed_published;   /* dxl_link_port_reply_publish came: the checksum may be taken */
  uint8_t armed_end;      /* ring index just after the armed packet's checksum */
  /* The reply. */
  uint8_t reply_state;    /* DXL_LINK_REPLY_* */
  const uint8_t *reply_bytes;
  uint8_t reply_length;
  uint8_t reply_published;
  uint16_t reply_delay_us;
  uint64_t reply_start_us; /* when the reply is due (WAITING / SENDING) */
  unsigned reply_load_count; /* replies loaded (listen, send) since fake_uart_init */
  /* The board. */
  uint8_t baud_register;  /* the last dxl_after_port_set_baud */
  uint8_t stored[CT_EEPROM_SIZE]; /* the last table stored */
  unsigned store_count;
  char log[FAKE_UART_LOG_BYTES];
  bool log_full;
  /* Optional hooks: a store and a new baud (each after it is recorded), a packet handled. */
  void (*on_store)(void *context, const uint8_t *table);
  void (*on_baud)(void *context, uint8_t baud_register);
  void (*on_handled)(void *context, dxl_find_result_t found, const uint8_t *bytes, uint16_t length,
                     const dxl_response_t *response);
  void *context;
};

void fake_uart_init(fake_uart_t *uart, uint8_t baud_register);

/* A byte arrives at now_us and is framed; false when it was to go into a full ring (lost). */
bool fake_uart_receive(fake_uart_t *uart, uint8_t byte);

/* The reply on the wire has left (SENDING or WAITING -> DONE). */
void fake_uart_reply_sent(fake_uart_t *uart);

/* As the RX interrupt at the last byte but one of a packet of this servo whose checksum comes
 * next (call it after that byte): arms the loaded reply (a PING's ready reply; anything else
 * streams its first DXL_STREAM_HEADER_BYTES). */
void fake_uart_arm(fake_uart_t *uart, bool ping);

/* As the RX interrupt at the armed packet's checksum: the byte is received and the reply starts
 * (matched) or goes back to IDLE. */
void fake_uart_checksum(fake_uart_t *uart, uint8_t byte, bool matched);

/* The received_count index of the first byte (the FF FF before the ID) of the kept packet whose
 * first byte is the pushed_at-th byte put into the ring (the link took it as its
 * (taken_count - held)-th); UINT64_MAX if it is not one of the last FAKE_UART_STARTS. */
uint64_t fake_uart_wire_index(const fake_uart_t *uart, uint64_t pushed_at);

/* The bytes of the reply the UART can send so far: reply_bytes[0..published). */
static inline uint8_t fake_uart_reply_ready(const fake_uart_t *uart) { return uart->reply_published; }

/* Appends text to the event log. */
void fake_uart_log(fake_uart_t *uart, const char *text);

#endif
