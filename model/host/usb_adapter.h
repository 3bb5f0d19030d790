/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The USB serial adapter between a client and the bus (`serve --adapter KIND`), as a timing
 * model in simulated time: pure, no I/O, no clock of its own (docs/emulator.md "The USB
 * adapter", where every figure below is cited).
 *
 * Kinds:
 *   wire           no adapter: each byte reaches the client when its stop bit ends on the
 *                  wire, a client's write enters the wire at once, any baud is exact.
 *   u2d2           ROBOTIS U2D2: an FTDI hi-speed chip (FT232H class): USB 2.0 high speed,
 *                  512-byte bulk packets (2 status bytes + 510 data), 125 us microframes,
 *                  baud generator 12 MHz / (n + k/8), 1 KB buffers each way.
 *   usb2dynamixel  ROBOTIS USB2Dynamixel: FTDI FT232R: full speed, 64-byte packets
 *                  (2 + 62 data), 1 ms frames, baud generator 3 MHz / (n + k/8), buffers of
 *                  256 B (host to bus) and 128 B (bus to host).
 *
 * Bus to host (FTDI AN232B-04): the chip holds the bytes it receives and sends them to the
 * host in one USB packet when the packet's data part is full, or when its latency timer
 * expires. The timer measures the time since the chip last sent a packet to the host and
 * restarts at every packet; when it expires with nothing held the chip sends the 2 status
 * bytes alone (the host polls without pause), so the timer is a free-running grid of period
 * latency, re-phased only by a packet that filled. A byte whose stop bit ends exactly at an
 * expiry waits for the next one.
 *
 * Host to bus: a client's write leaves the host in the first USB (micro)frame that starts at
 * or after it (bulk OUT modelled at frame starts), then goes out at the chip's baud.
 *
 * Units: times in simulated CPU cycles (sim_time.h), rates in bit/s, sizes in bytes. */
#ifndef SIM_USB_ADAPTER_H
#define SIM_USB_ADAPTER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "sim_time.h"

typedef enum {
  USB_ADAPTER_WIRE = 0,
  USB_ADAPTER_U2D2,
  USB_ADAPTER_USB2DYNAMIXEL,
} usb_adapter_kind_t;

#define USB_ADAPTER_LATENCY_MIN_MS 1u
#define USB_ADAPTER_LATENCY_MAX_MS 255u
/* ROBOTIS's advice for its adapters (docs/emulator.md cites it); Linux's own default is 16. */
#define USB_ADAPTER_DEFAULT_LATENCY_MS 1u
/* The default of `serve --adapter` (docs/emulator.md says why). */
#define USB_ADAPTER_DEFAULT_KIND USB_ADAPTER_U2D2

/* Linux's usb-serial write FIFO (one page) that ftdi_sio fills before a client's write blocks. */
#define USB_ADAPTER_HOST_WRITE_FIFO_BYTES 4096u

typedef struct {
  usb_adapter_kind_t kind;
  unsigned latency_ms; /* 1..255; unused by wire */
} usb_adapter_config_t;

/* The fixed figures of a kind's chip. */
typedef struct {
  const char *name;      /* the --adapter keyword */
  const char *chip;      /* "FT232H class", "FT232R", "none" */
  uint32_t packet_bytes; /* USB bulk packet (IN and OUT); 0 for wire */
  uint32_t status_bytes; /* per IN packet (2 on FTDI chips) */
  uint32_t frame_ns;     /* USB (micro)frame: 125000 high speed, 1000000 full speed; 0 for wire */
  uint32_t to_bus_buffer_bytes;   /* chip buffer, host to bus */
  uint32_t to_host_buffer_bytes;  /* chip buffer, bus to host */
  double baud_base_hz;   /* baud = base / (divisor / 8), divisor in eighths; 0 for wire */
  double max_bps;        /* above it Linux's ftdi_sio sets 9600 instead */
} usb_adapter_chip_t;

const usb_adapter_chip_t *usb_adapter_chip(usb_adapter_kind_t kind);

/* Parses KIND or KIND:LATENCY_MS (u2d2, u2d2:16, usb2dynamixel:1, wire). False with a one-line
 * reason in err for an unknown kind, a latency outside 1..255 or not a whole number, or a
 * latency given to wire. */
bool usb_adapter_parse(const char *text, usb_adapter_config_t *config, char *err, size_t err_len);

/* "u2d2:1 (FT232H class, latency 1 ms)" or "wire". */
void usb_adapter_describe(const usb_adapter_config_t *config, char *out, size_t out_len);

/* The rate the chip produces when a client asks for requested_bps (Linux ftdi_sio's divisor:
 * the nearest eighth step, 9600 above the chip's maximum). Wire: requested_bps. */
double usb_adapter_actual_bps(usb_adapter_kind_t kind, double requested_bps);

/* A packet the chip sends to the host: `bytes` data bytes (the next ones from the bus, in
 * order) that reach the client at `at`. */
typedef struct {
  sim_cycles_t at;
  uint32_t bytes;
} usb_adapter_packet_t;

#define USB_ADAPTER_PACKET_RING 64u

typedef struct {
  uint64_t in_packets;        /* packets with data sent to the host */
  uint64_t in_bytes;          /* data bytes in them */
  uint64_t in_full_packets;   /* sent because they filled */
  uint64_t in_timer_packets;  /* sent when the latency timer expired */
  uint64_t in_status_only;    /* timer expiries with nothing held (2 status bytes alone) */
  uint64_t max_in_bytes;      /* largest data part sent */
  sim_cycles_t latency_wait_total; /* sum over timer packets of (send - last byte's end) */
  sim_cycles_t latency_wait_max;
  uint64_t out_writes;        /* client writes put on the wire */
  uint64_t out_packets;       /* USB OUT packets they took */
  uint64_t out_bytes;
  sim_cycles_t frame_wait_total; /* sum over writes of (frame start - write's arrival) */
  uint64_t held_max;          /* most bytes held in the chip for the host at once */
} usb_adapter_stats_t;

typedef struct {
  usb_adapter_config_t config;
  const usb_adapter_chip_t *chip;
  sim_cycles_t latency_cycles;
  sim_cycles_t frame_cycles;
  uint32_t payload_bytes;     /* data bytes per IN packet (packet - status) */
  /* Bus to host. */
  sim_cycles_t timer_start;   /* last packet to the host: the latency timer counts from here */
  uint32_t held;              /* bytes received, not yet sent to the host */
  sim_cycles_t last_end;      /* end of the last byte received */
  usb_adapter_packet_t ring[USB_ADAPTER_PACKET_RING];
  uint32_t ring_head, ring_count;
  usb_adapter_stats_t stats;
} usb_adapter_t;

/* A fresh adapter whose latency timer starts at time start. */
void usb_adapter_init(usb_adapter_t *a, const usb_adapter_config_t *config, sim_cycles_t start);

/* Bus to host. Feed every byte from the bus in order with the end of its stop bit (non-
 * decreasing); packets become ready for usb_adapter_pop. usb_adapter_advance(t) lets the
 * timer run to t (inclusive) with no new byte. Call usb_adapter_pop until false after each
 * call, or packets wait (the ring holds USB_ADAPTER_PACKET_RING; a byte or an advance with a
 * full ring aborts: a caller bug). */
void usb_adapter_rx_byte(usb_adapter_t *a, sim_cycles_t end);
void usb_adapter_advance(usb_adapter_t *a, sim_cycles_t t);
bool usb_adapter_pop(usb_adapter_t *a, usb_adapter_packet_t *packet);

/* When held bytes will be sent if no more come (the next timer expiry), or SIM_CYCLES_NEVER
 * when nothing is held. */
sim_cycles_t usb_adapter_next_release(const usb_adapter_t *a);

/* Host to bus: a client write of `bytes` that reached the host's driver at `arrival` enters
 * the wire at the returned time (the next frame start; wire: arrival). Counts the write. */
sim_cycles_t usb_adapter_tx_write(usb_adapter_t *a, sim_cycles_t arrival, uint32_t bytes);

/* Bytes a client may have written and not yet on the wire before its writes block (the host
 * driver's FIFO plus the chip's buffer); 0 for wire (no bound of its own). */
uint32_t usb_adapter_tx_queue_limit(const usb_adapter_t *a);

#endif
