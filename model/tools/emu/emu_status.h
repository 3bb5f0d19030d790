/* SPDX-License-Identifier: GPL-3.0-or-later */
/* What the control protocol tells of the servos (docs/dashboard.md "The control socket"): each
 * servo's firmware state (read from RAM, servo_probe.h), its plant and its world, as JSON. */
#ifndef EMU_STATUS_H
#define EMU_STATUS_H

#include <stdbool.h>
#include <stdint.h>

#include <cjson/cJSON.h>

#include "emu_realtime.h"
#include "pacing.h"
#include "plant_options.h"
#include "pty_bridge.h"
#include "servo_probe.h"
#include "world.h"
#include "world_robot.h"

/* The bus's servos as the control protocol sees them. */
typedef struct {
  world_t *world;
  plant_options_t *worlds; /* each servo's world now, world->servo_count of them */
  const uint8_t *slot_ids; /* each servo's --ids entry */
  servo_probe_map_t map;   /* where the firmware keeps its table */
  /* Real time's figures ("timing"; pacing NULL: none). */
  const pacing_t *pacing;
  const pty_bridge_t *pty;
  const emu_realtime_t *realtime;
  world_robot_t *robot;    /* --robot's, NULL when none */
} emu_servos_t;

/* The robot's joint that servo `index` (of the world) drives, NULL when none. */
const robot_binding_t *emu_servo_joint(const emu_servos_t *v, size_t index);

/* The answer to "status" (event false: "ok", "op") or a "telemetry" event: the time, the
 * profile and MCU, "timing" (the scheduling policy and its state: held, dropped while late,
 * not allowed, fast; the lag now and at worst, the delays of the client's bytes to the bus and
 * of the hand-overs to the client, p50 / p99 / max in ms: docs/dashboard.md), every servo
 * (only_slots not NULL: those whose --ids entry it marks, 256 entries); with_table adds each
 * control table; with_robot the robot's pose (emu_robot.h), when there is a robot. */
cJSON *emu_status_json(const emu_servos_t *v, bool event, bool with_table, const bool *only_slots, bool with_robot);

/* A servo's world options as the protocol names them. */
cJSON *emu_world_json(const plant_options_t *o);

#endif
