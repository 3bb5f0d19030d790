/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The robot on the control protocol (docs/robot.md "The robot on the control socket"): what a
 * 3D view needs to draw it (bodies, geoms with their types, sizes, colours and poses in their
 * body, meshes), its pose now (every body's position and orientation in the world frame, z
 * up, metres), and its world (gravity, payloads, pushes), with the "robot" request that
 * changes that world while it runs:
 *   {"op":"robot"}                                      the description, its world, its pose
 *   {"op":"robot","set":{"payload":{"body":"tip","kg":0.3},
 *                        "push":{"body":"body","force_n":[0,20,0],"seconds":0.2},
 *                        "gravity":false}}              changes (any of them; "payload" and
 *                                                       "push" also as arrays), all checked
 *                                                       before any is made */
#ifndef EMU_ROBOT_H
#define EMU_ROBOT_H

#include <stddef.h>

#include <cjson/cJSON.h>

#include "world_robot.h"

/* Bodies, joints, geoms and meshes, its world and its pose. */
cJSON *emu_robot_description_json(const world_robot_t *robot);

/* The pose now: {"time_s", "steps", "poses": [[x, y, z, qw, qx, qy, qz] per body, the world
 * body's first], "world"}: the telemetry's "robot". */
cJSON *emu_robot_pose_json(const world_robot_t *robot);

/* {"gravity", "gravity_m_s2", "payloads": [{"body", "kg"}], "pushes": [{"body", "force_n",
 * "seconds_left"}]}. */
cJSON *emu_robot_world_json(const world_robot_t *robot);

/* The "robot" request: the answer, or NULL with err set and nothing changed. */
cJSON *emu_robot_request(world_robot_t *robot, const cJSON *req, char *err, size_t err_len);

#endif
