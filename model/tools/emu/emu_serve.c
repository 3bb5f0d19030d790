/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The serve loop (contract in emu_serve.h): the world with its servos (emu_state_files.h) on
 * their plants, the pty bridge, the bus log, the control socket and the dashboard, the trace and
 * gdb (emu_debug_tools.h) opened; the boot until every servo listens; then runs of the
 * world of at most SLICE_US, cut at the next client byte, adapter hand-over or control event,
 * each followed by the pty, the control socket and the bus log, and paced (pacing.h); at a stop
 * signal (emu_stop_signal.h) the settling, the state files, the trace, the statistics
 * (emu_stats.h) and the exit status. */
#include "emu_serve.h"

#include <stdio.h>

#include "emu_bus_log.h"
#include "emu_control.h"
#include "emu_dashboard.h"
#include "emu_debug_tools.h"
#include "emu_firmware_choice.h"
#include "emu_state_files.h"
#include "emu_stats.h"
#include "emu_stop_signal.h"
#include "pacing.h"
#include "pty_bridge.h"
#include "servo.h"
#include "servo_plant.h"
#include "world.h"

#define SLICE_US 100u
#define BOOT_LIMIT_MS 2000u
#define SHUTDOWN_SETTLE_MS 500u
#define LAG_REPORT_US 20000.0
#define LAG_REPORT_PERIOD_US 10e6

static sim_cycles_t sim_of_wall(void *ctx, double wall_us) { return pacing_sim_at(ctx, wall_us); }

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
  /* The pty starts at the first servo's baud, so a client that sets none still talks. */
  uint8_t first_baud = (uint8_t)o->baud;
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

  static emu_control_t control;
  bool control_open = false;
  if (o->control_path[0]) {
    control_open = emu_control_open(&control, o->control_path, world, &pty, worlds, o->ids, o->elf,
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

  pacing_t pacing;
  pacing_start(&pacing, o->realtime, world->now);
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
  printf("ready: %s\n", pty.device);
  fflush(stdout);
  char adapter_name[96];
  usb_adapter_describe(&o->adapter, adapter_name, sizeof(adapter_name));
  fprintf(stderr, "ax12-emu: %zu servo%s (%s, %s%s) on %s%s%s, adapter %s, state in %s, %s\n", world->servo_count,
          world->servo_count == 1 ? "" : "s", eeprom_profile_name(o->profile), o->mcu,
          o->bootloader[0] ? ", bootloader" : "", pty.device, o->link ? " = " : "", o->link ? o->link : "", adapter_name,
          o->state_dir, o->realtime ? "real time" : "fast");

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
    world_run_until(world, until);
    emu_debug_after_run(&debug);
    (void)pty_bridge_pump(&pty, o->realtime ? sim_of_wall : NULL, &pacing);
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
      (void)pty_bridge_pump(&pty, o->realtime ? sim_of_wall : NULL, &pacing);
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

  emu_dashboard_stop(&dashboard);
  if (control_open) {
    emu_control_close(&control);
  }
  emu_debug_close_gdb(&debug);
  const int failures = world_settle_and_persist(world, sim_ms(SHUTDOWN_SETTLE_MS));
  const bool traced = emu_debug_close_trace(&debug, world, true);
  if (failures) {
    for (size_t i = 0; i < world->servo_count; i++) {
      if (world->servos[i]->persist_errors) {
        fprintf(stderr, "ax12-emu: %s: %s\n", world->servos[i]->name, world->servos[i]->last_error);
      }
    }
  }
  if (o->stats) {
    emu_stats_print(world, &pty, &pacing);
  }
  const int log_failed = emu_bus_log_stop(&bus_logging, o->stats);
  pty_bridge_close(&pty);
  world_destroy(world);
  emu_state_locks_release(&locks); /* after the last state file was written */
  return failures || log_failed || !traced ? 1 : 0;
}

