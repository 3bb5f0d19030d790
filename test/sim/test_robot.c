/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A robot of AX-12s (docs/robot.md): the firmware ELF of every servo in simavr, its plant's
 * motor driving a joint of a MuJoCo model stepped in lock (model/simavr/world_robot.c), seen
 * through the protocol. The pendulum's static droop at two compliance slopes against the
 * compliance law of docs/control.md and the plant's torque; a payload the servo cannot hold:
 * Overload after 1 s, torque shutdown as Alarm Shutdown says; torque off: the fall against
 * MuJoCo alone with the same armature, friction and damping; the same traffic twice (one
 * thread, two threads) gives the same joint trajectories bit for bit; the model's checks. All
 * in simulated time. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "dxl_protocol.h"
#include "dxl_table.h"
#include "plant_joint.h"
#include "plant_options.h"
#include "sim_harness.h"
#include "world_robot.h"

#ifndef AX12_ROBOTS_DIR
#error "AX12_ROBOTS_DIR must be defined by the build"
#endif

#define DEG_PER_RAD (180.0 / M_PI)
#define COUNTS_PER_DEG (1024.0 / 300.0)

typedef struct {
  harness_t h;
  robot_model_t model;
  world_robot_t robot;
  servo_t *servos[ROBOT_MAX_BINDINGS];
  uint8_t last_error;
  /* qpos of every physics step, when recording */
  double *history;
  size_t history_len, history_cap;
} rig_t;

static void record(world_robot_t *robot, void *ctx) {
  rig_t *r = ctx;
  const int nq = robot->model->model->nq;
  if (r->history_len + (size_t)nq > r->history_cap) {
    r->history_cap = (r->history_cap + (size_t)nq) * 2u;
    r->history = realloc(r->history, r->history_cap * sizeof(double));
    assert_non_null(r->history);
  }
  memcpy(r->history + r->history_len, robot->physics.data->qpos, (size_t)nq * sizeof(double));
  r->history_len += (size_t)nq;
}

/* The robot's servos on their plants (the default world), bound to its joints; gravity as
 * given from the start; booted. */
static void rig_open(rig_t *r, const char *robot, bool gravity, unsigned threads) {
  memset(r, 0, sizeof(*r));
  harness_open(&r->h, "ax12", "atmega88", 1);
  (void)world_set_threads(r->h.world, threads);
  char err[512];
  if (!robot_model_load(&r->model, robot, AX12_ROBOTS_DIR, err, sizeof err)) {
    fail_msg("%s", err);
  }
  plant_options_t world;
  plant_options_default(&world);
  for (size_t i = 0; i < r->model.binding_count; i++) {
    r->servos[i] = harness_add_servo(&r->h, r->model.bindings[i].id, 1, NULL);
    ax12_plant_t plant;
    plant_options_build(&world, &plant);
    servo_attach_plant(r->servos[i], &plant);
  }
  if (!world_robot_attach(&r->robot, r->h.world, &r->model, r->servos, err, sizeof err)) {
    fail_msg("%s", err);
  }
  robot_physics_set_gravity(&r->robot.physics, gravity);
  harness_boot(&r->h, 300);
}

static void rig_close(rig_t *r) {
  world_robot_detach(&r->robot);
  harness_close(&r->h);
  robot_model_free(&r->model);
  free(r->history);
}

static void run_ms(rig_t *r, unsigned ms) { world_run_until(r->h.world, r->h.world->now + sim_ms(ms)); }

static void write_bytes(rig_t *r, uint8_t id, uint8_t addr, const uint8_t *data, size_t n) {
  uint8_t params[16] = {addr};
  memcpy(params + 1, data, n);
  uint8_t reply[64];
  assert_int_equal(harness_request(&r->h, id, DXL_INST_WRITE, params, n + 1u, 6u, reply), 6u);
  r->last_error = reply[4];
}

static void write_u8(rig_t *r, uint8_t id, uint8_t addr, uint8_t v) { write_bytes(r, id, addr, &v, 1); }

static void write_u16(rig_t *r, uint8_t id, uint8_t addr, uint16_t v) {
  const uint8_t d[2] = {(uint8_t)(v & 0xFFu), (uint8_t)(v >> 8)};
  write_bytes(r, id, addr, d, 2);
}

static uint16_t read_n(rig_t *r, uint8_t id, uint8_t addr, uint8_t n) {
  uint8_t reply[64];
  assert_int_equal(harness_request(&r->h, id, DXL_INST_READ, HP(addr, n), 6u + n, reply), 6u + n);
  r->last_error = reply[4];
  return n == 1 ? reply[5] : (uint16_t)(reply[5] | (reply[6] << 8));
}

static uint8_t read_u8(rig_t *r, uint8_t id, uint8_t addr) { return (uint8_t)read_n(r, id, addr, 1); }
static uint16_t read_u16(rig_t *r, uint8_t id, uint8_t addr) { return read_n(r, id, addr, 2); }

static double joint_deg(const rig_t *r, size_t binding) {
  return robot_physics_joint_angle_rad(&r->robot.physics, binding) * DEG_PER_RAD;
}

/* docs/control.md "The compliance curve as implemented": the drive at error e > margin. */
static int compliance_drive(int e, int margin, int slope, int punch, int limit) {
  if (e <= margin) {
    return 0;
  }
  int k = 1;
  while ((1 << k) < slope) {
    k++;
  }
  const int p = punch < limit ? punch : limit;
  const int d = p + (((limit - p) * (e - margin)) >> k);
  return d < limit ? d : limit;
}

/* The pendulum's gravity torque on its joint at angle_deg, at rest: MuJoCo's own bias force on
 * a copy of the data (the robot's model, payload and gravity included). */
static double gravity_torque_nm(rig_t *r, double angle_deg) {
  const mjModel *m = r->model.model;
  mjData *d = mj_makeData(m);
  mj_copyData(d, m, r->robot.physics.data);
  d->qpos[r->model.bindings[0].qpos] = angle_deg / DEG_PER_RAD;
  d->qvel[r->model.bindings[0].dof] = 0.0;
  mj_forward(m, d);
  const double down_nm = d->qfrc_bias[r->model.bindings[0].dof]; /* what holds it up must give this */
  mj_deleteData(d);
  return down_nm;
}

/* ---- the pendulum's static droop ---- */

/* The arm lowered slowly onto Goal Position 512 (horizontal) with torque on: it sinks until
 * the drive of the compliance law, through the motor (the plant's torque at that duty) and
 * the gear friction that turns with it (the gears hold more than they lift: the sinking arm
 * back-drives them), carries the arm's weight. The predicted droop is the smallest error whose
 * drive does. */
static void droop_at_slope(uint8_t slope) {
  rig_t r;
  rig_open(&r, "pendulum", false, 1);
  char err[256];
  assert_true(robot_physics_set_payload(&r.robot.physics, "tip", 0.3, err, sizeof err)); /* 0.5 kg at 150 mm */
  write_u8(&r, 1, CT_ADDR_CW_COMPLIANCE_SLOPE, slope);
  write_u8(&r, 1, CT_ADDR_CCW_COMPLIANCE_SLOPE, slope);
  write_u8(&r, 1, CT_ADDR_TORQUE_ENABLE, 1);
  write_u16(&r, 1, CT_ADDR_GOAL_POSITION, 600);
  run_ms(&r, 600);
  robot_physics_set_gravity(&r.robot.physics, true);
  run_ms(&r, 600);
  write_u16(&r, 1, CT_ADDR_MOVING_SPEED, 20); /* 45 counts a second: the arm follows quasi-statically */
  write_u16(&r, 1, CT_ADDR_GOAL_POSITION, 512);
  run_ms(&r, 3500);
  const int position = read_u16(&r, 1, CT_ADDR_PRESENT_POSITION);
  const int load = read_u16(&r, 1, CT_ADDR_PRESENT_LOAD);
  assert_int_equal(read_u8(&r, 1, CT_ADDR_MOVING), 1); /* still out of margin + 2 counts of the goal */

  const int margin = read_u8(&r, 1, CT_ADDR_CW_COMPLIANCE_MARGIN);
  const int punch = read_u16(&r, 1, CT_ADDR_PUNCH);
  const int limit = read_u16(&r, 1, CT_ADDR_TORQUE_LIMIT);
  const ax12_plant_t *plant = &r.servos[0]->plant;
  int predicted = -1;
  double hold_nm = 0.0, weight_nm = 0.0;
  for (int e = margin + 1; e < 200 && predicted < 0; e++) {
    const int drive = compliance_drive(e, margin, slope, punch, limit);
    const double duty = (double)(drive * 255 / 1023) / 255.0; /* OCR0A, floored */
    const double drive_nm = ax12_plant_output_drive_nm(plant, duty, 0.0, NULL);
    hold_nm = drive_nm + ax12_plant_joint_frictionloss_nm(plant, drive_nm);
    weight_nm = gravity_torque_nm(&r, -(double)e / COUNTS_PER_DEG);
    if (hold_nm >= weight_nm) {
      predicted = e;
    }
  }
  const int droop = 512 - position;
  print_message("slope %u: droop %d counts (predicted %d: %.3f N m held of %.3f N m), Present Load %d, joint %.2f deg\n",
                slope, droop, predicted, hold_nm, weight_nm, load, joint_deg(&r, 0));
  assert_true(predicted > margin + 1);
  assert_in_range(droop, predicted - 1, predicted + 1);
  /* Present Load is the drive the law gives at that error (CCW: bit 10 clear), the share of
   * the full drive that carries the arm. */
  assert_int_equal(load, compliance_drive(droop, margin, slope, punch, limit));
  /* The pot reads the joint (count = 512 + joint angle x 1024 / 300 deg, truncated). */
  assert_in_range(position, (int)floor(512.0 + joint_deg(&r, 0) * COUNTS_PER_DEG) - 1,
                  (int)floor(512.0 + joint_deg(&r, 0) * COUNTS_PER_DEG) + 1);
  rig_close(&r);
}

static void test_pendulum_droop_slope_32(void **state) {
  (void)state;
  droop_at_slope(32);
}

static void test_pendulum_droop_slope_128(void **state) {
  (void)state;
  droop_at_slope(128);
}

/* ---- overload ---- */

/* A payload heavier than the gears and motor hold at full drive: the arm sinks, Overload
 * holds from 1 s after the drive reached Torque Limit (docs/policy.md), and torque goes off
 * only when Alarm Shutdown has the overload bit. */
static void overload(bool shutdown) {
  rig_t r;
  rig_open(&r, "pendulum", false, 1);
  if (shutdown) {
    write_u8(&r, 1, CT_ADDR_ALARM_SHUTDOWN, DXL_ERR_OVERLOAD | DXL_ERR_OVERHEATING);
  }
  write_u8(&r, 1, CT_ADDR_TORQUE_ENABLE, 1);
  write_u16(&r, 1, CT_ADDR_GOAL_POSITION, 512);
  run_ms(&r, 300);
  char err[256];
  assert_true(robot_physics_set_payload(&r.robot.physics, "tip", 2.5, err, sizeof err));
  const double full_drive_nm = ax12_plant_output_drive_nm(&r.servos[0]->plant, 1.0, 0.0, NULL);
  const double full_hold_nm = full_drive_nm + ax12_plant_joint_holding_friction_nm(&r.servos[0]->plant, full_drive_nm);
  robot_physics_set_gravity(&r.robot.physics, true);
  assert_true(gravity_torque_nm(&r, 0.0) > full_hold_nm * 1.2);
  const sim_cycles_t on = r.h.world->now;
  sim_cycles_t at_limit = 0, tripped = 0;
  while (!tripped && r.h.world->now - on < sim_ms(3000)) {
    run_ms(&r, 5);
    const uint16_t load = read_u16(&r, 1, CT_ADDR_PRESENT_LOAD);
    if (!at_limit && (load & 0x3FFu) == 1023u) {
      at_limit = r.h.world->now;
    }
    if (r.last_error & DXL_ERR_OVERLOAD) {
      tripped = r.h.world->now;
    }
  }
  assert_true(at_limit != 0);
  assert_true(tripped != 0);
  const double after_ms = (double)(tripped - at_limit) / SIM_CYCLES_PER_US / 1000.0;
  print_message("overload %s: drive at the limit %.0f ms after the payload, Overload %.0f ms later, joint %.1f deg\n",
                shutdown ? "with shutdown" : "without shutdown", (double)(at_limit - on) / 16000.0, after_ms,
                joint_deg(&r, 0));
  assert_true(joint_deg(&r, 0) < -20.0); /* the arm sank */
  assert_in_range((long)after_ms, 990, 1020);
  run_ms(&r, 50);
  assert_int_equal(read_u8(&r, 1, CT_ADDR_TORQUE_ENABLE), shutdown ? 0 : 1);
  assert_true(r.last_error & DXL_ERR_OVERLOAD);
  double lowest_deg = joint_deg(&r, 0);
  for (unsigned ms = 0; ms < 1500; ms += 5) {
    run_ms(&r, 5);
    lowest_deg = fmin(lowest_deg, joint_deg(&r, 0));
  }
  if (shutdown) {
    assert_true(lowest_deg < -85.0); /* torque off: the arm swings down past hanging */
    assert_int_equal(read_u16(&r, 1, CT_ADDR_PRESENT_LOAD) & 0x3FFu, 0);
  } else {
    assert_true(joint_deg(&r, 0) > -80.0); /* still pulling: held off the bottom */
    assert_int_equal(read_u16(&r, 1, CT_ADDR_PRESENT_LOAD), 1023);
  }
  rig_close(&r);
}

static void test_overload_without_shutdown(void **state) {
  (void)state;
  overload(false);
}

static void test_overload_shuts_torque_off(void **state) {
  (void)state;
  overload(true);
}

/* ---- torque off: the fall against MuJoCo alone ---- */

/* Seconds until the joint first passes below each angle of deg[], stepping MuJoCo alone on
 * the model with the servo's armature, coasting friction and damping on the joint. */
static void fall_alone(const double *deg, size_t n, double *t_s) {
  robot_model_t model;
  char err[256];
  assert_true(robot_model_load(&model, "pendulum", AX12_ROBOTS_DIR, err, sizeof err));
  mjModel *m = model.model;
  mjData *d = mj_makeData(m);
  ax12_plant_t plant;
  ax12_plant_init(&plant, NULL);
  ax12_plant_joint_set_motion(&plant, 0.0, -1.0); /* turning, duty 0: the coasting joint's terms */
  ax12_joint_drive_t none = {0};
  const ax12_joint_torque_t coast = ax12_plant_joint_take(&plant, &none);
  const int dof = model.bindings[0].dof;
  m->dof_armature[dof] = ax12_plant_joint_armature_kg_m2(&plant);
  m->dof_damping[dof] = coast.damping_nm_s_rad;
  m->dof_frictionloss[dof] = coast.frictionloss_nm;
  m->dof_solref[mjNREF * dof] = ROBOT_FRICTION_TIMECONST_STEPS * m->opt.timestep;
  m->dof_solimp[mjNIMP * dof] = m->dof_solimp[mjNIMP * dof + 1] = ROBOT_FRICTION_IMPEDANCE;
  d->qfrc_applied[dof] = coast.applied_nm;
  /* the comparison holds while the coasting bridge's body diodes stay off: below the speed
   * whose back-EMF passes the supply and two diode drops, where the coasting joint has one
   * friction and one damping (beyond it the diodes brake, docs/plant.md) */
  const double clamp_rad_s = ax12_bridge_clamp_v(&plant.params.bridge, ax12_supply_terminal_v(&plant.params.supply, 0.0)) /
                             (plant.params.motor.kt_nm_a * plant.params.gearbox.ratio);
  double fastest_rad_s = 0.0;
  size_t k = 0;
  while (k < n && d->time < 5.0) {
    mj_step(m, d);
    fastest_rad_s = fmax(fastest_rad_s, fabs(d->qvel[dof]));
    while (k < n && d->qpos[model.bindings[0].qpos] * DEG_PER_RAD < deg[k]) {
      t_s[k++] = d->time;
    }
  }
  assert_int_equal(k, n);
  print_message("fastest %.2f rad/s, the diodes conduct from %.2f rad/s\n", fastest_rad_s, clamp_rad_s);
  assert_true(fastest_rad_s < clamp_rad_s);
  mj_deleteData(d);
  robot_model_free(&model);
}

static void test_torque_off_fall_matches_mujoco_alone(void **state) {
  (void)state;
  const double deg[] = {-10.0, -30.0, -60.0, -85.0};
  double alone_s[4], coupled_s[4];
  fall_alone(deg, 4, alone_s);

  rig_t r;
  memset(&r, 0, sizeof r);
  harness_open(&r.h, "ax12", "atmega88", 1);
  char err[512];
  assert_true(robot_model_load(&r.model, "pendulum", AX12_ROBOTS_DIR, err, sizeof err));
  r.servos[0] = harness_add_servo(&r.h, 1, 1, NULL);
  ax12_plant_t plant;
  ax12_plant_init(&plant, NULL);
  servo_attach_plant(r.servos[0], &plant);
  assert_true(world_robot_attach(&r.robot, r.h.world, &r.model, r.servos, err, sizeof err));
  /* From power-up, torque off (the firmware's default): the arm falls from horizontal. */
  size_t k = 0;
  while (k < 4 && r.h.world->now < sim_ms(5000)) {
    run_ms(&r, 1);
    while (k < 4 && joint_deg(&r, 0) < deg[k]) {
      coupled_s[k++] = world_robot_time_s(&r.robot);
    }
  }
  assert_int_equal(k, 4);
  assert_int_equal(read_u8(&r, 1, CT_ADDR_TORQUE_ENABLE), 0);
  for (size_t i = 0; i < 4; i++) {
    print_message("below %.0f deg: %.4f s coupled, %.4f s MuJoCo alone\n", deg[i], coupled_s[i], alone_s[i]);
    assert_true(fabs(coupled_s[i] - alone_s[i]) <= 0.02 * alone_s[i]);
  }
  rig_close(&r);
}

/* ---- determinism ---- */

/* The same scripted traffic (goals to the arm's servos at fixed simulated times) on a fresh
 * world: the history of every physics step's qpos. */
static void scripted_arm_run(rig_t *r, unsigned threads) {
  rig_open(r, "arm", true, threads);
  r->robot.after_physics = record;
  r->robot.after_physics_ctx = r;
  for (uint8_t id = 1; id <= 5; id++) {
    write_u8(r, id, CT_ADDR_TORQUE_ENABLE, 1);
  }
  static const uint16_t goals[3][5] = {{600, 430, 600, 500, 560}, {420, 560, 450, 600, 470}, {512, 512, 512, 512, 512}};
  for (unsigned step = 0; step < 3; step++) {
    world_run_until(r->h.world, sim_ms(600 + 500 * step));
    for (uint8_t id = 1; id <= 5; id++) {
      write_u16(r, id, CT_ADDR_GOAL_POSITION, goals[step][id - 1]);
    }
  }
  world_run_until(r->h.world, sim_ms(2500));
}

static void test_same_traffic_same_trajectories(void **state) {
  (void)state;
  rig_t a, b;
  scripted_arm_run(&a, 1);
  scripted_arm_run(&b, 2);
  assert_true(a.history_len > 1000u);
  assert_int_equal(a.history_len, b.history_len);
  assert_memory_equal(a.history, b.history, a.history_len * sizeof(double));
  /* and the arm did move */
  double travel = 0.0;
  for (size_t i = a.model.model->nq; i < a.history_len; i++) {
    travel += fabs(a.history[i] - a.history[i - (size_t)a.model.model->nq]);
  }
  assert_true(travel > 1.0);
  rig_close(&a);
  rig_close(&b);
}

/* ---- the model's checks ---- */

static void expect_refused(const char *xml, const char *message_part) {
  char path[] = "/tmp/ax12-robot-XXXXXX.xml";
  const int fd = mkstemps(path, 4);
  assert_true(fd >= 0);
  assert_int_equal(write(fd, xml, strlen(xml)), (ssize_t)strlen(xml));
  close(fd);
  robot_model_t model;
  char err[512] = "";
  const bool loaded = robot_model_load(&model, path, AX12_ROBOTS_DIR, err, sizeof err);
  unlink(path);
  if (loaded) {
    robot_model_free(&model);
  }
  print_message("refused: %s\n", err);
  assert_false(loaded);
  assert_non_null(strstr(err, message_part));
  assert_null(strchr(err, '\n'));
}

#define ARM(custom, joint)                                                                                         \
  "<mujoco><custom>" custom "</custom><worldbody><body name=\"b\"><joint name=\"j\" " joint                       \
  "/><geom size=\"0.1\" mass=\"1\"/><body name=\"c\"><joint name=\"k\" type=\"hinge\"/><geom size=\"0.1\" "        \
  "mass=\"1\"/></body></body></worldbody></mujoco>"

static void test_bad_models_refused(void **state) {
  (void)state;
  expect_refused("<mujoco><worldbody><body></mujoco>", "does not load");
  expect_refused(ARM("<numeric name=\"ax12:nope\" data=\"1\"/>", "type=\"hinge\""), "names no joint 'nope'");
  expect_refused(ARM("<numeric name=\"ax12:j\" data=\"3\"/><numeric name=\"ax12:k\" data=\"3\"/>", "type=\"hinge\""),
                 "both bound to servo 3");
  expect_refused(ARM("<numeric name=\"ax12:j\" data=\"1\"/>", "type=\"hinge\" range=\"-170 100\""),
                 "outside the pot's track");
  expect_refused(ARM("<numeric name=\"ax12:j\" data=\"1\"/>", "type=\"slide\""), "not a hinge");
  expect_refused(ARM("<numeric name=\"ax12:j\" data=\"254\"/>", "type=\"hinge\""), "whole number 0..253");
  expect_refused(ARM("<numeric name=\"other\" data=\"1\"/>", "type=\"hinge\""), "binds no joint");
  robot_model_t model;
  char err[256];
  /* a timestep that does not divide 1 ms: the next one below that does */
  const double timesteps[][2] = {{0.002, 0.001}, {0.001, 0.001}, {0.0003, 0.00025}, {0.0005, 0.0005}};
  for (size_t i = 0; i < 4; i++) {
    char xml[512], path[] = "/tmp/ax12-robot-XXXXXX.xml";
    snprintf(xml, sizeof xml, "<mujoco><option timestep=\"%g\"/><custom><numeric name=\"ax12:j\" data=\"1\"/></custom>"
             "<worldbody><body><joint name=\"j\"/><geom size=\"0.1\"/></body></worldbody></mujoco>", timesteps[i][0]);
    const int fd = mkstemps(path, 4);
    assert_int_equal(write(fd, xml, strlen(xml)), (ssize_t)strlen(xml));
    close(fd);
    const bool loaded = robot_model_load(&model, path, AX12_ROBOTS_DIR, err, sizeof err);
    unlink(path);
    assert_true(loaded);
    assert_float_equal(model.model->opt.timestep, timesteps[i][1], 1e-12);
    assert_int_equal(model.steps_per_ms, (unsigned)llround(1e-3 / timesteps[i][1]));
    robot_model_free(&model);
  }
  assert_false(robot_model_load(&model, "no-such-robot", AX12_ROBOTS_DIR, err, sizeof err));
  assert_non_null(strstr(err, "unknown robot 'no-such-robot'"));
  /* the shipped robots load, with their servos */
  const char *robots[] = {"pendulum", "arm", "hexapod"};
  const size_t servos[] = {1, 5, 18};
  for (size_t i = 0; i < 3; i++) {
    assert_true(robot_model_load(&model, robots[i], AX12_ROBOTS_DIR, err, sizeof err));
    assert_int_equal(model.binding_count, servos[i]);
    robot_model_free(&model);
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_bad_models_refused),
      cmocka_unit_test(test_pendulum_droop_slope_32),
      cmocka_unit_test(test_pendulum_droop_slope_128),
      cmocka_unit_test(test_overload_without_shutdown),
      cmocka_unit_test(test_overload_shuts_torque_off),
      cmocka_unit_test(test_torque_off_fall_matches_mujoco_alone),
      cmocka_unit_test(test_same_traffic_same_trajectories),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
