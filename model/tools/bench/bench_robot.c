/* SPDX-License-Identifier: GPL-3.0-or-later */
/* ax12-bench robot: a robot of AX-12s (docs/robot.md) as `serve --robot` runs it, every servo on
 * its plant and bound to its joint, the physics stepped in lock (world_robot.h), measured
 * unthrottled: holding a pose with torque on, then under the zero-latency client loop of the
 * issue (a SYNC_WRITE of goals, then a READ of Present Position from every servo, each reply
 * awaited). scripts/bench runs it under callgrind for the physics' share of the host's cost:
 * the instructions inside robot_physics_step (MuJoCo's step) against those inside
 * bench_robot_loops (the whole loaded window). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench_commands.h"
#include "bench_rig.h"
#include "dxl_protocol.h"
#include "dxl_table.h"
#include "plant_options.h"
#include "servo_plant.h"
#include "world_robot.h"

#ifndef AX12_ROBOTS_DIR
#error "AX12_ROBOTS_DIR must be defined by the build"
#endif

/* Goals near the joints' zero (the robots' standing pose), swaying by 20 counts every 50 loops. */
static size_t sync_write_goals(uint8_t *out, const robot_model_t *model, unsigned loop) {
  uint8_t params[2 + 3 * ROBOT_MAX_BINDINGS];
  size_t n = 0;
  params[n++] = CT_ADDR_GOAL_POSITION;
  params[n++] = 2;
  const unsigned goal = (loop / 50u) & 1u ? 532u : 512u;
  for (size_t i = 0; i < model->binding_count; i++) {
    params[n++] = model->bindings[i].id;
    params[n++] = (uint8_t)(goal & 0xFFu);
    params[n++] = (uint8_t)(goal >> 8);
  }
  return packet_encode(out, DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE, params, n);
}

static void sync_write_byte(bench_rig_t *r, const robot_model_t *model, uint8_t addr, uint8_t value) {
  uint8_t params[2 + 2 * ROBOT_MAX_BINDINGS], p[8 + sizeof params];
  size_t n = 0;
  params[n++] = addr;
  params[n++] = 1;
  for (size_t i = 0; i < model->binding_count; i++) {
    params[n++] = model->bindings[i].id;
    params[n++] = value;
  }
  master_send(r->master, p, packet_encode(p, DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE, params, n));
}

/* CPU seconds this process has used: a speed per CPU second is what the simulation makes of a
 * core of its own, whatever else the machine runs. */
static double cpu_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return (double)t.tv_sec + (double)t.tv_nsec / 1e9;
}

/* The client loop until simulated time `until`; returns the loops completed. */
unsigned bench_robot_loops(bench_rig_t *r, const robot_model_t *model, sim_cycles_t until);
unsigned bench_robot_loops(bench_rig_t *r, const robot_model_t *model, sim_cycles_t until) {
  uint8_t p[8 + 3 * ROBOT_MAX_BINDINGS];
  unsigned loops = 0;
  while (r->world->now < until) {
    master_send(r->master, p, sync_write_goals(p, model, loops));
    for (size_t i = 0; i < model->binding_count; i++) {
      uint8_t q[8], params[2] = {CT_ADDR_PRESENT_POSITION, 2};
      bench_exchange(r, q, packet_encode(q, model->bindings[i].id, DXL_INST_READ, params, 2), 8);
    }
    loops++;
  }
  return loops;
}

void bench_robot(const char *robot, double seconds) {
  char err[1024];
  robot_model_t model;
  if (!robot_model_load(&model, robot, AX12_ROBOTS_DIR, err, sizeof err)) bench_die("--robot", err);
  uint8_t ids[ROBOT_MAX_BINDINGS];
  for (size_t i = 0; i < model.binding_count; i++) {
    ids[i] = model.bindings[i].id;
  }
  bench_rig_t r;
  bench_rig_create(&r, ids, model.binding_count);
  plant_options_t world;
  plant_options_default(&world);
  for (size_t i = 0; i < r.world->servo_count; i++) {
    ax12_plant_t plant;
    plant_options_build(&world, &plant);
    servo_attach_plant(r.world->servos[i], &plant);
  }
  static world_robot_t bot;
  if (!world_robot_attach(&bot, r.world, &model, r.world->servos, err, sizeof err)) bench_die("--robot", err);
  bench_rig_power_up(&r);
  /* torque on toward the standing pose, then 2 s to get there */
  uint8_t p[8 + 3 * ROBOT_MAX_BINDINGS];
  sync_write_byte(&r, &model, CT_ADDR_MOVING_SPEED, 100);
  master_send(r.master, p, sync_write_goals(p, &model, 0));
  sync_write_byte(&r, &model, CT_ADDR_TORQUE_ENABLE, 1);
  world_run_until(r.world, r.world->now + MS(2000));

  const sim_cycles_t span = (sim_cycles_t)(seconds * 1e6 * SIM_CYCLES_PER_US);
  double w0 = bench_wall_s(), c0 = cpu_s();
  world_run_until(r.world, r.world->now + span);
  const double holding_wall = bench_wall_s() - w0, holding_cpu = cpu_s() - c0;
  const uint64_t steps0 = bot.physics.steps;
  w0 = bench_wall_s();
  c0 = cpu_s();
  const sim_cycles_t t0 = r.world->now;
  const unsigned loops = bench_robot_loops(&r, &model, t0 + span);
  const double loaded_wall = bench_wall_s() - w0, loaded_cpu = cpu_s() - c0;
  const double loaded_sim = (double)(r.world->now - t0) / SIM_CYCLES_PER_US / 1e6;
  printf("{\"robot\": \"%s\", \"servos\": %zu, \"holding_sim_s_per_wall_s\": %.3f, \"holding_sim_s_per_cpu_s\": %.3f, "
         "\"loaded_sim_s_per_wall_s\": %.3f, \"loaded_sim_s_per_cpu_s\": %.3f, \"client_loops_per_sim_s\": %.1f, "
         "\"loaded_sim_s\": %.6f, \"physics_steps\": %llu}\n",
         model.name, model.binding_count, seconds / holding_wall, seconds / holding_cpu, loaded_sim / loaded_wall,
         loaded_sim / loaded_cpu, loops / loaded_sim, loaded_sim, (unsigned long long)(bot.physics.steps - steps0));
  world_robot_detach(&bot);
  bench_rig_close(&r);
  robot_model_free(&model);
}
