/* SPDX-License-Identifier: GPL-3.0-or-later */
/* `ax12-emu serve`'s control protocol on its control socket (control_socket.h): what the live
 * dashboard and `ax12 world` ask of a running emulator (docs/dashboard.md "The control
 * socket"). One JSON object a line each way:
 *   {"op":"status"}                            every servo now (servo_probe.h), its world, and
 *                                              "device": the pty the clients open
 *   {"op":"status","table":true}               ... with each control table
 *   {"op":"world","id":3,"set":{"load-torque":1.2}}   change servo 3's world (or "id":"all");
 *                                              the names and ranges of the command line's
 *                                              world options, plus "load-none"
 *   {"op":"send","bytes":"FF FF 03 04 03 19 01 DB"}  a Protocol 1.0 packet onto the bus as a
 *                                              second master, once the bus is idle; the
 *                                              answer holds the servo's reply bytes
 *   {"op":"robot"} / {"op":"robot","set":{...}} the robot (--robot): its description, pose and
 *                                              world, or a change of its world (emu_robot.h)
 *   {"op":"subscribe","telemetry_hz":25,"table":true,"packets":true,"servos":[3]}
 *                                              status lines pushed at that rate (1..100 Hz;
 *                                              0 stops), with the control tables ("table_hz":
 *                                              5 instead: in events at most that often),
 *                                              of the servos listed ("servos", slot IDs) or all and, with "packets", every packet of
 *                                              the bus monitor (bus_monitor.h), in batches
 *                                              {"event":"packets","packets":[...]} at most
 *                                              PACKET_BATCH_PERIOD_US apart; with a robot,
 *                                              its pose in every telemetry event unless
 *                                              "robot":false
 * Every request gets one line back: {"ok":true,...} or {"ok":false,"error":"..."}; pushed lines
 * carry "event" instead. A bad request changes nothing. */
#ifndef EMU_CONTROL_H
#define EMU_CONTROL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "bus_monitor.h"
#include "control_socket.h"
#include "emu_bus_master.h"
#include "emu_packet_stream.h"
#include "emu_status.h"
#include "plant_options.h"
#include "pty_bridge.h"
#include "world.h"

typedef struct {
  control_socket_t socket;
  emu_servos_t servos;
  emu_bus_master_t master;      /* "send" */
  emu_packet_stream_t packets;  /* "packets" subscriptions */
  /* Per client: telemetry period (0 = none) and when it is next due (wall us); tables in it
   * (with_table), at most table_period_us apart when that is not 0; packets or not. */
  double period_us[CONTROL_MAX_CLIENTS];
  double due_us[CONTROL_MAX_CLIENTS];
  bool with_table[CONTROL_MAX_CLIENTS];
  double table_period_us[CONTROL_MAX_CLIENTS];
  double table_due_us[CONTROL_MAX_CLIENTS];
  bool with_packets[CONTROL_MAX_CLIENTS];
  bool without_robot[CONTROL_MAX_CLIENTS];  /* "robot":false: no pose in its telemetry */
  bool filtered[CONTROL_MAX_CLIENTS];       /* telemetry of only_slots[client] only */
  bool only_slots[CONTROL_MAX_CLIENTS][256];
  double next_poll_us; /* wall clock */
  const char *device;  /* the pty's path (pty_bridge_t.device) */
} emu_control_t;

/* Opens the socket at path. worlds and slot_ids: one per servo of the world, kept by the
 * caller; worlds are updated by "world" requests; robot: --robot's, NULL when none. *monitor: the bus monitor of --log-bus when
 * there is one (else NULL: one is made while packets are subscribed). -1 with err set. */
int emu_control_open(emu_control_t *c, const char *path, world_t *world, world_robot_t *robot, pty_bridge_t *pty,
                     plant_options_t *worlds, const uint8_t *slot_ids, const char *elf_path,
                     bus_monitor_t **monitor, char *err, size_t err_len);
void emu_control_close(emu_control_t *c);

/* Status and telemetry carry "timing" from these from now on (emu_status.h). */
void emu_control_show_timing(emu_control_t *c, const pacing_t *pacing, const pty_bridge_t *pty,
                             const emu_realtime_t *realtime);

/* Between world steps: requests, pushed telemetry and packets, and the packet on the bus. */
void emu_control_poll(emu_control_t *c);

/* While a packet of "send" waits or is on the bus, the world must step no further than this
 * before the next poll; else SIM_CYCLES_NEVER. */
sim_cycles_t emu_control_next_event(const emu_control_t *c);

#endif
