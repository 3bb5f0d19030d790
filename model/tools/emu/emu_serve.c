/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The serve loop (contract in emu_serve.h): the world with its servos (emu_state_files.h) on
 * their plants and the robot whose joints some drive (world_robot.h), the pty bridge, the bus
 * log, the joint log and the scripted master of --play-bus, the control socket and the
 * dashboard, the trace and gdb (emu_debug_tools.h) opened; in real time the state files written
 * behind the simulation (state_write_behind.h) and the real-time scheduling policy taken
 * (emu_realtime.h); the boot until every servo listens; then runs of the world of at most
 * SLICE_US, cut at the next client byte, adapter hand-over, control event or --play-bus row,
 * each followed by the pty, the control socket, the played rows and the logs, and paced
 * (pacing.h), the first WARM_UP_MS of them before `ready:`; at a stop signal
 * (emu_stop_signal.h) the settling, the state files, the trace, the statistics (emu_stats.h)
 * and the exit status. */
#include "emu_serve.h"

#include <stdio.h>

#include "eeprom_store.h"
#include "emu_bus_log.h"
#include "emu_bus_play.h"
#include "emu_control.h"
#include "emu_dashboard.h"
#include "emu_debug_tools.h"
#include "emu_firmware_choice.h"
#include "emu_realtime.h"
#include "emu_joint_log.h"
#include "emu_state_files.h"
#include "emu_stats.h"
#include "emu_stop_signal.h"
#include "pacing.h"
#include "pty_bridge.h"
#include "servo.h"
#include "servo_plant.h"
#include "state_write_behind.h"
#include "world.h"
#include "world_robot.h"

#define SLICE_US 100u
#define BOOT_LIMIT_MS 2000u
#define SHUTDOWN_SETTLE_MS 500u
#define LAG_REPORT_US 20000.0
#define LAG_REPORT_PERIOD_US 10e6
#define WARM_UP_MS 10u              /* simulated, after the boot, before `ready:` */
#define WARM_UP_LAG_US 500.0        /* ... then `ready:` once on time within this */
#define WARM_UP_MAX_WALL_MS 500.0   /* ... or after this long, if the host cannot keep up */

/* For the start-up line: "; slot 1 answers at ID 7, slot 2 answers at 57143 bit/s (saved settings)",
 * each servo whose saved ID is not its slot's (the --ids entry) or whose saved Baud Rate is not
 * the one asked for (--baud); "" when none. */
static void describe_saved_settings(const world_t *world, const serve_options_t *o, char *out, size_t out_len) {
  size_t used = 0;
  out[0] = '\0';
  for (size_t i = 0; i < world->servo_count && used < out_len; i++) {
    uint8_t id = 0, baud_reg = 0;
    if (!eeprom_store_image_fields(world->servos[i]->eeprom, world->servos[i]->eeprom_size, &id, &baud_reg)) {
      continue;
    }
    const bool other_id = id != o->ids[i], other_baud = baud_reg != o->baud_register;
    if (!other_id && !other_baud) {
      continue;
    }
    char id_text[16] = "", baud_text[32] = "";
    if (other_id) {
      snprintf(id_text, sizeof(id_text), " ID %u", id);
    }
    if (other_baud) {
      snprintf(baud_text, sizeof(baud_text), "%s %.0f bit/s", other_id ? "," : "", sim_baud_reg_to_bps(baud_reg));
    }
    const int n = snprintf(out + used, out_len - used, "%s slot %u answers at%s%s", used ? "," : ";", o->ids[i],
                           id_text, baud_text);
    used = n < 0 ? out_len : used + (size_t)n;
  }
  if (used && used < out_len) {
    snprintf(out + used, out_len - used, " (saved settings)");
  }
}

/* `ready: <device>` on stdout, then the line that says what runs, on stderr. */
static void announce_ready(const serve_options_t *o, const world_t *world, const pty_bridge_t *pty) {
  printf("ready: %s\n", pty->device);
  fflush(stdout);
  char adapter_name[96];
  usb_adapter_describe(&o->adapter, adapter_name, sizeof(adapter_name));
  char saved[512];
  describe_saved_settings(world, o, saved, sizeof(saved));
  fprintf(stderr, "ax12-emu: %zu servo%s (%s, %s%s) on %s%s%s, adapter %s, state in %s, %s%s\n", world->servo_count,
          world->servo_count == 1 ? "" : "s", eeprom_profile_name(o->profile), o->mcu,
          o->bootloader[0] ? ", bootloader" : "", pty->device, o->link ? " = " : "", o->link ? o->link : "",
          adapter_name, o->state_dir, o->realtime ? "real time" : "fast", saved);
  if (o->robot) {
    fprintf(stderr, "ax12-emu: robot %s (%s): %zu servo%s on its joints, physics every %g ms in lock-step\n",
            o->robot->name, o->robot->path, o->robot->binding_count, o->robot->binding_count == 1 ? "" : "s",
            1.0 / o->robot->steps_per_ms);
  }
}

/* --robot: the model's joints bound to their servos (world_robot.h); a bound servo's world
 * keeps no load of its own. False with a line on stderr. */
static bool attach_robot(world_robot_t *robot, world_t *world, const serve_options_t *o, plant_options_t *worlds) {
  servo_t *bound[ROBOT_MAX_BINDINGS] = {0};
  for (size_t b = 0; b < o->robot->binding_count; b++) {
    for (size_t i = 0; i < world->servo_count; i++) {
      if (o->ids[i] == o->robot->bindings[b].id) {
        bound[b] = world->servos[i];
        worlds[i].load = ax12_load_none();
        worlds[i].load_option = NULL;
      }
    }
  }
  char err[512];
  if (!world_robot_attach(robot, world, o->robot, bound, err, sizeof(err))) {
    fprintf(stderr, "ax12-emu: --robot: %s\n", err);
    return false;
  }
  return true;
}

int emu_serve(const serve_options_t *o) {
  char err[512];
  world_t *world = world_create(o->elf, o->mcu, o->profile, err, sizeof(err));
  if (!world) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    return 1;
  }
  if (o->bootloader[0] && !world_set_bootloader(world, o->bootloader, err, sizeof(err))) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    world_destroy(world);
    return 1;
  }
  emu_firmware_say(o);
  (void)bus_set_noise(&world->bus, o->bit_error_rate, o->noise_seed); /* validated by the parser */
  emu_state_locks_t locks;
  if (!emu_state_files_add_servos(world, o, &locks)) {
    world_destroy(world);
    return 1;
  }
  /* Each servo's world: the bus-wide options with its own --world ones over them; changed
   * at run time through the control socket. */
  static plant_options_t worlds[WORLD_MAX_SERVOS];
  for (size_t i = 0; i < world->servo_count; i++) {
    ax12_plant_t plant;
    (void)emu_servo_world(o, o->ids[i], &worlds[i], err, sizeof(err)); /* checked by the parser */
    plant_options_build(&worlds[i], &plant);
    servo_attach_plant(world->servos[i], &plant);
  }
  static world_robot_t robot;
  if (o->robot && !attach_robot(&robot, world, o, worlds)) {
    emu_state_locks_release(&locks);
    world_destroy(world);
    return 1;
  }
  world_robot_t *robot_or_null = o->robot ? &robot : NULL;
  /* The pty starts at the first servo's baud, so a client that sets none still talks. */
  uint8_t first_baud = (uint8_t)o->baud_register;
  (void)eeprom_store_image_fields(world->servos[0]->eeprom, world->servos[0]->eeprom_size, NULL, &first_baud);
  pty_bridge_t pty;
  if (pty_bridge_open(&pty, &world->bus, &world->now, sim_baud_reg_to_bps(first_baud), &o->adapter, o->link, err,
                      sizeof(err)) != 0) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    emu_state_locks_release(&locks);
    world_destroy(world);
    return 1;
  }
  emu_bus_log_t bus_logging;
  if (emu_bus_log_start(&bus_logging, o->log_bus, &world->bus, pty.node, err, sizeof(err)) != 0) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    pty_bridge_close(&pty);
    emu_state_locks_release(&locks);
    world_destroy(world);
    return 1;
  }
  emu_joint_log_t joint_log = {0};
  emu_bus_play_t play = o->play; /* its rows, read by the parser (o->play_bus NULL: none) */
  if ((o->log_joints && emu_joint_log_start(&joint_log, o->log_joints, &robot, err, sizeof(err)) != 0) ||
      (o->play_bus && emu_bus_play_start(&play, world, sim_baud_reg_to_bps(first_baud), err, sizeof(err)) != 0)) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    (void)emu_bus_log_stop(&bus_logging, false);
    pty_bridge_close(&pty);
    emu_state_locks_release(&locks);
    world_destroy(world);
    return 1;
  }

  static pacing_t pacing;            /* started before the boot; the control socket reports it */
  static emu_realtime_t realtime;
  static emu_control_t control;
  bool control_open = false;
  if (o->control_path[0]) {
    control_open = emu_control_open(&control, o->control_path, world, robot_or_null, &pty, worlds, o->ids, o->elf,
                                    &bus_logging.monitor, err, sizeof(err)) == 0;
    if (!control_open && o->control_explicit) {
      fprintf(stderr, "ax12-emu: %s\n", err);
      pty_bridge_close(&pty);
      emu_state_locks_release(&locks);
      world_destroy(world);
      return 1;
    }
    if (!control_open) {
      fprintf(stderr, "ax12-emu: warning: %s; running without a control socket (give one with --control)\n", err);
    }
  } else if (o->control_explicit) {
    fprintf(stderr, "ax12-emu: --control: the path is too long\n");
  }
  emu_dashboard_t dashboard = {.out_fd = -1}; /* not running */
  if (o->dashboard) {
    if (!control_open || emu_dashboard_start(&dashboard, o->control_path, o->dashboard, err, sizeof(err)) != 0) {
      fprintf(stderr, "ax12-emu: --dashboard: %s\n", control_open ? err : "it needs the control socket");
      if (control_open) {
        emu_control_close(&control);
      }
      (void)emu_bus_log_stop(&bus_logging, false);
      pty_bridge_close(&pty);
      emu_state_locks_release(&locks);
      world_destroy(world);
      return 1;
    }
    fprintf(stderr, "ax12-emu: dashboard at %s\n", dashboard.url);
  }

  emu_debug_tools_t debug;
  if (!emu_debug_open(&debug, world, o, err, sizeof(err))) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    emu_debug_close_gdb(&debug);
    (void)emu_debug_close_trace(&debug, world, false);
    emu_dashboard_stop(&dashboard);
    if (control_open) {
      emu_control_close(&control);
    }
    (void)emu_bus_log_stop(&bus_logging, false);
    pty_bridge_close(&pty);
    emu_state_locks_release(&locks);
    world_destroy(world);
    return 1;
  }

  emu_stop_signal_install();

  /* In real time the state files are written behind the simulation (state_write_behind.h). */
  if (o->realtime && state_write_behind_start(err, sizeof(err)) != 0) {
    fprintf(stderr, "ax12-emu: warning: %s; state files are written in the simulation's own time\n", err);
  }
  pacing_start(&pacing, o->realtime, world->now);
  emu_realtime_take(&realtime, o->realtime, &pacing, &pty);
  if (control_open) {
    emu_control_show_timing(&control, &pacing, &pty, &realtime);
  }
  const sim_cycles_t slice = sim_us(SLICE_US);

  /* Boot: until every servo listens on the bus (its application, when a bootloader runs first). */
  bool booted = false;
  while (!emu_stop_requested() && world->now < sim_ms(BOOT_LIMIT_MS)) {
    emu_debug_wait_while_held(&debug, world, &pacing);
    booted = true;
    for (size_t i = 0; i < world->servo_count; i++) {
      booted &= servo_ready_for_clients(world->servos[i], world->now);
    }
    if (booted) {
      break;
    }
    world_run_until(world, world->now + slice);
    emu_debug_after_run(&debug);
    (void)pacing_wait(&pacing, world->now, -1);
  }
  if (!booted && !emu_stop_requested()) {
    fprintf(stderr, "ax12-emu: warning: not every servo enabled its UART within %u ms\n", BOOT_LIMIT_MS);
  }
  /* Warm-up: the boot runs every servo awake (30 of them take about 6 times longer than real
   * time), and no client can have seen its lag: the clocks are re-aligned rather than the lag
   * caught up after `ready:`; then the serve loop runs WARM_UP_MS of the steady state, in real
   * time, before `ready:` (docs/emulator.md "Real time on a busy machine"). */
  realtime.boot_sim_us = sim_cycles_to_us(world->now);
  realtime.boot_wall_us = pacing_wall_us() - pacing.started_wall_us;
  pacing_resume(&pacing, world->now);
  const sim_cycles_t warm_until = world->now + sim_ms(WARM_UP_MS);
  const double warm_start_us = pacing_wall_us();
  const double warm_deadline_us = warm_start_us + WARM_UP_MAX_WALL_MS * 1e3;
  bool announced = false;

  bool warned_persist = false;
  double lag_report_at_us = pacing_wall_us() + LAG_REPORT_PERIOD_US;
  double lag_reported_us = 0.0;
  while (!emu_stop_requested()) {
    emu_debug_wait_while_held(&debug, world, &pacing);
    if (emu_stop_requested()) {
      break;
    }
    /* Up to the next client byte's arrival at most (it enters the wire at that exact time),
     * and to the adapter's next hand-over to the client (its latency timer). */
    sim_cycles_t until = world->now + slice;
    const sim_cycles_t next_input = pty_bridge_next_input(&pty);
    if (next_input > world->now && next_input < until) {
      until = next_input;
    }
    const sim_cycles_t next_output = pty_bridge_next_output(&pty);
    if (next_output > world->now && next_output < until) {
      until = next_output;
    }
    if (control_open) {
      const sim_cycles_t next_control = emu_control_next_event(&control);
      if (next_control < until) {
        until = next_control;
      }
    }
    const sim_cycles_t next_play = emu_bus_play_next(&play); /* --play-bus: each row at its time */
    if (next_play > world->now && next_play < until) {
      until = next_play;
    }
    world_run_until(world, until);
    emu_debug_after_run(&debug);
    emu_bus_play_poll(&play, world->now);
    emu_joint_log_tick(&joint_log);
    (void)pty_bridge_pump(&pty, o->realtime ? &pacing : NULL);
    if (control_open) {
      emu_control_poll(&control);
    }
    emu_bus_log_tick(&bus_logging, world->now);
    if (!warned_persist) {
      for (size_t i = 0; i < world->servo_count; i++) {
        if (world->servos[i]->persist_errors) {
          fprintf(stderr, "ax12-emu: %s: %s\n", world->servos[i]->name, world->servos[i]->last_error);
          warned_persist = true;
        }
      }
    }
    world_park(world);
    if (pacing_wait(&pacing, world->now, pty_bridge_wake_fd(&pty))) {
      (void)pty_bridge_pump(&pty, o->realtime ? &pacing : NULL);
    }
    if (!announced && world->now >= warm_until &&
        (!o->realtime || pacing_ahead_us(&pacing, world->now) >= -WARM_UP_LAG_US ||
         pacing_wall_us() >= warm_deadline_us)) {
      if (state_write_behind_flush(err, sizeof(err)) != 0) { /* `ready:`: the boot's state is on disk */
        fprintf(stderr, "ax12-emu: %s\n", err);
      }
      pacing_restart(&pacing, world->now); /* the figures (lag, speed) are those of the serving */
      realtime.warm_wall_us = pacing.started_wall_us - warm_start_us;
      announce_ready(o, world, &pty);
      announced = true;
      lag_report_at_us = pacing_wall_us() + LAG_REPORT_PERIOD_US;
    }
    if (o->realtime && pacing_wall_us() >= lag_report_at_us) {
      /* At most one line per period, only when the lag grew past the threshold. */
      const double lag = pacing.max_behind_us;
      if (lag > LAG_REPORT_US && lag > lag_reported_us) {
        fprintf(stderr, "ax12-emu: warning: the simulation ran up to %.0f ms behind real time (%.2fx overall)\n",
                lag / 1e3, pacing_speed(&pacing, world->now));
        lag_reported_us = lag;
      }
      lag_report_at_us = pacing_wall_us() + LAG_REPORT_PERIOD_US;
    }
  }

  pacing_stop(&pacing, world->now);
  emu_dashboard_stop(&dashboard);
  if (control_open) {
    emu_control_close(&control);
  }
  emu_debug_close_gdb(&debug);
  pacing_release_rt(&pacing); /* the settling runs flat out: not at a real-time policy */
  int failures = world_settle_and_persist(world, sim_ms(SHUTDOWN_SETTLE_MS));
  const int unwritten = state_write_behind_stop(err, sizeof(err)); /* every state file on disk */
  if (unwritten) {
    fprintf(stderr, "ax12-emu: %d state file write%s failed: %s\n", unwritten, unwritten == 1 ? "" : "s", err);
    failures += unwritten;
  }
  const int joint_log_failed = o->robot ? emu_joint_log_stop(&joint_log, &robot) : 0;
  if (o->robot) {
    world_robot_detach(&robot);
  }
  const bool traced = emu_debug_close_trace(&debug, world, true);
  if (failures) {
    for (size_t i = 0; i < world->servo_count; i++) {
      if (world->servos[i]->persist_errors) {
        fprintf(stderr, "ax12-emu: %s: %s\n", world->servos[i]->name, world->servos[i]->last_error);
      }
    }
  }
  if (o->stats) {
    emu_stats_print(world, &pty, &pacing, &realtime);
  }
  const int log_failed = emu_bus_log_stop(&bus_logging, o->stats);
  pty_bridge_close(&pty);
  world_destroy(world);
  emu_bus_play_free(&play);
  emu_state_locks_release(&locks); /* after the last state file was written */
  return failures || log_failed || joint_log_failed || !traced ? 1 : 0;
}

