/* SPDX-License-Identifier: MIT */
/* The bus monitor: every byte the bus finalizes (its tap, bus_set_tap) grouped, sender by
 * sender, into Dynamixel Protocol 1.0 packets, each handed to the listeners as one record
 * (bus_packet_t). Pure C, no simavr.
 *
 * Framing, per sender, by the rule every reader follows (docs/policy.md "Framing and bus",
 * firmware/core/dxl_frame.h, whose step it runs):
 * - A packet is FF FF (more FF tolerated) ID LENGTH code params... checksum, LENGTH >= 2
 *   counting the bytes after it. code is the instruction when the client sent it
 *   (bus_monitor_set_client), the error byte of a status packet when a servo did.
 * - It is framed by its LENGTH: a wrong checksum gives a record with checksum_ok false, the
 *   packet's bytes consumed (as a servo frames a packet for another ID).
 * - Bytes that start no packet (before a header, a header with a LENGTH below 2) are garbage;
 *   consecutive garbage bytes make one BUS_PACKET_GARBAGE record.
 * - A Protocol 2.0 frame (FF FF FD 00 ID LEN_L LEN_H ...) is skipped whole by its 16-bit
 *   length and reported as BUS_PACKET_PROTOCOL2 (a long one in several records), so FF FF
 *   inside it never starts a 1.0 packet.
 * - A partial packet ends, its bytes reported as garbage (a 2.0 frame's as such), when its
 *   sender is silent for longer than the gap (seen at its next byte or at bus_monitor_flush),
 *   when another sender starts a byte after the partial packet's last byte ended (it took the
 *   wire; a byte that collided with any other, as in replies sent in lockstep, ends nothing),
 *   or at bus_monitor_finish.
 *
 * Records come in the order they complete (a partial packet ended by another sender's byte is
 * reported before the packet that byte begins). Everything runs on the thread that finalizes
 * the bus; listeners must not call back into the monitor or the bus. */
#ifndef MODEL_BUS_MONITOR_H
#define MODEL_BUS_MONITOR_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "bus.h"
#include "sim_time.h"

/* The gap after which a servo discards a partial packet (docs/policy.md "Framing and bus"):
 * the monitor's default. */
#define BUS_MONITOR_DEFAULT_GAP_US 100000u
/* Bytes one record holds at most: the longest 1.0 packet (259 with a two-byte header) with
 * room for extra header bytes; longer garbage or 2.0 frames come in several records. */
#define BUS_MONITOR_MAX_RAW 320u
#define BUS_MONITOR_MAX_LISTENERS 8u

typedef enum {
  BUS_PACKET_INSTRUCTION, /* a 1.0 packet from the client */
  BUS_PACKET_STATUS,      /* a 1.0 packet from a servo (any node but the client) */
  BUS_PACKET_GARBAGE,     /* bytes that are no packet */
  BUS_PACKET_PROTOCOL2,   /* (part of) a Protocol 2.0 frame */
} bus_packet_kind_t;

/* One record. Pointers are valid during the listener's call only. */
typedef struct {
  bus_packet_kind_t kind;
  sim_cycles_t start;      /* start bit of the first byte */
  sim_cycles_t end;        /* end of the last byte's stop bit */
  uint8_t sender;          /* node index */
  const char *sender_name; /* "client" for the client, else the node's name ("servo-1") */
  /* Instruction and status packets only (0 otherwise): */
  uint8_t id;
  uint8_t length; /* the LENGTH byte */
  uint8_t code;   /* instruction (client) or error byte (servo) */
  const uint8_t *params;
  size_t param_count;
  uint8_t checksum; /* as sent */
  bool checksum_ok;
  /* Every kind: */
  bool collision;     /* a byte of it overlapped another sender's (BUS_RX_COLLISION) */
  uint8_t line_flags; /* OR of its bytes' BUS_RX_* flags (collision, truncation, noise) */
  bool noise_changed; /* the line's noise changed a byte (the values here are as sent) */
  const uint8_t *raw; /* every byte as sent, header to checksum */
  size_t raw_count;
} bus_packet_t;

typedef void (*bus_packet_fn)(void *ctx, const bus_packet_t *packet);

typedef struct bus_monitor bus_monitor_t;

/* A monitor of bus (whose node names it reads when it reports), with the given gap in cycles
 * (sim_us(BUS_MONITOR_DEFAULT_GAP_US) as a servo does), installed as the bus's tap. NULL when
 * out of memory. No client until bus_monitor_set_client: every 1.0 packet is then a status. */
bus_monitor_t *bus_monitor_create(bus_t *bus, sim_cycles_t gap);
/* Removes the tap and frees the monitor; partial packets are dropped unreported (call
 * bus_monitor_finish first to report them). */
void bus_monitor_destroy(bus_monitor_t *mon);

/* The node whose packets are instructions (the pty bridge, a test master). */
void bus_monitor_set_client(bus_monitor_t *mon, int node);
/* Another node whose packets are instructions, reported under its own name (a second master:
 * the dashboard's edits, emu_control.h). */
void bus_monitor_add_master(bus_monitor_t *mon, int node);

/* Adds a listener of every record from now on. Returns its handle (>= 0) for
 * bus_monitor_remove_listener, -1 when BUS_MONITOR_MAX_LISTENERS are there already. */
int bus_monitor_add_listener(bus_monitor_t *mon, bus_packet_fn fn, void *ctx);
void bus_monitor_remove_listener(bus_monitor_t *mon, int handle);

/* The tap itself (bus_tap_fn): one finalized byte. Exposed so that tests may feed bytes. */
void bus_monitor_byte(void *mon, const bus_tap_byte_t *byte);

/* Ends every partial packet whose sender has been silent longer than the gap at `now`. Call it
 * now and then (the serve loop does, every slice) so a cut packet is reported soon. */
void bus_monitor_flush(bus_monitor_t *mon, sim_cycles_t now);
/* Ends every partial packet now (the end of a run). */
void bus_monitor_finish(bus_monitor_t *mon);

/* Records reported so far, by kind (statistics). */
uint64_t bus_monitor_count(const bus_monitor_t *mon, bus_packet_kind_t kind);

#endif
