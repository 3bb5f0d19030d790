/* SPDX-License-Identifier: GPL-3.0-or-later */
/* `ax12-emu serve`'s control protocol on its control socket (control_socket.h): what the live
 * dashboard and `ax12 world` ask of a running emulator (docs/dashboard.md "The control
 * socket"). One JSON object a line each way:
 *   {"op":"status"}                            every servo now (servo_probe.h), its world
 *   {"op":"status","table":true}               ... with each control table
 *   {"op":"world","id":3,"set":{"load-torque":1.2}}   change servo 3's world (or "id":"all");
 *                                              the names and ranges of the command line's
 *                                              world options, plus "load-none"
 *   {"op":"send","bytes":"FF FF 03 04 03 19 01 DB"}  a Protocol 1.0 packet onto the bus as a
 *                                              second master, once the bus is idle; the
 *                                              answer holds the servo's reply bytes
 *   {"op":"subscribe","telemetry_hz":25,"table":true,"packets":true}
 *                                              status lines pushed at that rate (1..100 Hz;
 *                                              0 stops), with the control tables ("table_hz":
 *                                              5 instead: in events at most that often) and, with "packets", every packet of
 *                                              the bus monitor (bus_monitor.h), in batches
 *                                              {"event":"packets","packets":[...]} at most
 *                                              PACKET_BATCH_PERIOD_US apart
 * Every request gets one line back: {"ok":true,...} or {"ok":false,"error":"..."}; pushed lines
 * carry "event" instead. A bad request changes nothing. */
#ifndef EMU_CONTROL_H
#define EMU_CONTROL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "bus_monitor.h"
#include "control_socket.h"
#include "master.h"
#include "plant_options.h"
#include "pty_bridge.h"
#include "servo_probe.h"
#include "world.h"

#define EMU_CONTROL_QUEUE 16u
#define EMU_CONTROL_PACKET_MAX 256u
#define EMU_CONTROL_BATCH_MAX 4000u

typedef struct {
  unsigned client;
  uint8_t bytes[EMU_CONTROL_PACKET_MAX];
  size_t len;
} emu_control_send_t;

typedef struct {
  control_socket_t socket;
  world_t *world;
  pty_bridge_t *pty;
  plant_options_t *worlds; /* each servo's world now, world->servo_count of them */
  const uint8_t *slot_ids; /* each servo's --ids entry */
  servo_probe_map_t map;
  /* Per client: telemetry period (0 = none), when it is next due (wall us), table or not. */
  double period_us[CONTROL_MAX_CLIENTS];
  double due_us[CONTROL_MAX_CLIENTS];
  bool with_table[CONTROL_MAX_CLIENTS];
  double table_period_us[CONTROL_MAX_CLIENTS]; /* tables only this far apart (0: in every event) */
  double table_due_us[CONTROL_MAX_CLIENTS];
  /* Packets to put on the bus, the first one in flight once `sending`. */
  master_t *master;
  emu_control_send_t queue[EMU_CONTROL_QUEUE];
  size_t queue_head, queue_count;
  bool sending;
  sim_cycles_t last_rx_end; /* of the reply so far (0: none yet) */
  sim_cycles_t request_end; /* end of the packet's last byte on the wire */
  uint64_t sent_packets;
  /* The bus monitor's packets for subscribers: the monitor of --log-bus (*shared_monitor) or
   * one of its own while anyone subscribes; the batch waiting to go out. */
  bus_monitor_t **shared_monitor;
  bus_monitor_t *own_monitor;
  int listener;
  int client_node;
  bool with_packets[CONTROL_MAX_CLIENTS];
  void *batch; /* cJSON array */
  size_t batch_count;
  uint64_t packets_dropped; /* past EMU_CONTROL_BATCH_MAX in one batch */
  double batch_due_us;
  double next_poll_us; /* wall clock */
} emu_control_t;

/* Opens the socket at path. worlds and slot_ids: one per servo of the world, kept by the
 * caller; worlds are updated by "world" requests. *monitor: the bus monitor of --log-bus when
 * there is one (else NULL: one is made while packets are subscribed), client_node the pty's
 * node. -1 with err set. */
int emu_control_open(emu_control_t *c, const char *path, world_t *world, pty_bridge_t *pty,
                     plant_options_t *worlds, const uint8_t *slot_ids, const char *elf_path,
                     bus_monitor_t **monitor, char *err, size_t err_len);
void emu_control_close(emu_control_t *c);

/* Between world steps: requests, pushed telemetry, and the packet on the bus. */
void emu_control_poll(emu_control_t *c);

/* While a packet of "send" is on the bus, the world must step no further than this before the
 * next poll; else SIM_CYCLES_NEVER. */
sim_cycles_t emu_control_next_event(const emu_control_t *c);

#endif
