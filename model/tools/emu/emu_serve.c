/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include "emu_serve.h"

#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>

#include "emu_bus_log.h"
#include "emu_control.h"
#include "emu_dashboard.h"
#include "pacing.h"
#include "pty_bridge.h"
#include "servo.h"
#include "servo_eeprom.h"
#include "servo_gdb.h"
#include "servo_plant.h"
#include "state_lock.h"
#include "world.h"
#include "world_trace.h"

#define SLICE_US 100u
#define BOOT_LIMIT_MS 2000u
#define SHUTDOWN_SETTLE_MS 500u
#define LAG_REPORT_US 20000.0
#define LAG_REPORT_PERIOD_US 10e6
#define TRACE_FLUSH_PERIOD_US 100000.0 /* the VCD on disk lags at most this much wall time */
#define GDB_WAIT_US 50000u              /* while gdb holds the bus: its requests are waited for */

/* --trace and --gdb: the waveform file and the servo opened to gdb. */
typedef struct {
  world_trace_t *trace;
  const char *trace_path;
  double trace_flush_at_us;
  servo_gdb_t gdb;
  bool gdb_open;
} serve_debug_t;

static volatile sig_atomic_t stop_requested;

static void on_signal(int sig) {
  (void)sig;
  stop_requested = 1;
}

/* The adapter's figures: USB packets to the host and their size, latency-timer waits, client
 * writes and their frame waits, the baud the bus saw. */
static void print_adapter_stats(const pty_bridge_t *pty) {
  const usb_adapter_t *a = &pty->adapter;
  const usb_adapter_stats_t *st = &a->stats;
  char name[96];
  usb_adapter_describe(&a->config, name, sizeof(name));
  if (a->config.kind == USB_ADAPTER_WIRE) {
    fprintf(stderr, "ax12-emu: adapter wire: client baud %.0f (exact on the bus)\n", pty->bps);
    return;
  }
  fprintf(stderr,
          "ax12-emu: adapter %s: USB packets to the client %llu (%.1f bytes per packet, largest %llu; %llu full, "
          "%llu at the latency timer, %llu status-only), latency waits mean %.3f ms, max %.3f ms; client writes %llu "
          "in %llu USB packets, frame wait mean %.3f ms; client baud %.0f -> %.1f on the bus\n",
          name, (unsigned long long)st->in_packets, st->in_packets ? (double)st->in_bytes / (double)st->in_packets : 0.0,
          (unsigned long long)st->max_in_bytes, (unsigned long long)st->in_full_packets,
          (unsigned long long)st->in_timer_packets, (unsigned long long)st->in_status_only,
          st->in_timer_packets ? sim_cycles_to_us(st->latency_wait_total) / 1e3 / (double)st->in_timer_packets : 0.0,
          sim_cycles_to_us(st->latency_wait_max) / 1e3, (unsigned long long)st->out_writes,
          (unsigned long long)st->out_packets,
          st->out_writes ? sim_cycles_to_us(st->frame_wait_total) / 1e3 / (double)st->out_writes : 0.0, pty->bps,
          pty->actual_bps);
}

static void print_stats(const world_t *world, const pty_bridge_t *pty, const pacing_t *pacing) {
  fprintf(stderr, "ax12-emu: simulated %.3f s at %.2fx real time; ", sim_cycles_to_us(world->now) / 1e6,
          pacing_speed(pacing, world->now));
  if (pacing->realtime) {
    fprintf(stderr, "worst lag %.1f ms, %llu re-alignments; ", pacing->max_behind_us / 1e3,
            (unsigned long long)pacing->realignments);
  }
  fprintf(stderr, "client bytes in %llu, out %llu (dropped %llu); bus collisions %llu, baud mismatches %llu\n",
          (unsigned long long)pty->from_client, (unsigned long long)pty->to_client,
          (unsigned long long)pty->dropped_to_client, (unsigned long long)world->bus.collided_bytes,
          (unsigned long long)world->bus.mismatched_deliveries);
  print_adapter_stats(pty);
  if (world->bus.noise.bit_error_rate > 0.0) {
    fprintf(stderr, "ax12-emu: noise at %g per bit: %llu bytes corrupted, %llu bits flipped\n",
            world->bus.noise.bit_error_rate, (unsigned long long)world->bus.noise_corrupted_bytes,
            (unsigned long long)world->bus.noise_flipped_bits);
  }
  for (size_t i = 0; i < world->servo_count; i++) {
    const servo_t *s = world->servos[i];
    const uart_link_t *l = &s->board.link;
    fprintf(stderr,
            "ax12-emu: %s: rx %llu (overrun %llu, late %llu), tx %llu (undriven %llu), EEPROM writes %llu, "
            "persisted %llu, flash pages erased or written %llu (persisted %llu), watchdog resets %llu%s\n",
            s->name, (unsigned long long)l->rx_bytes, (unsigned long long)l->rx_overruns,
            (unsigned long long)l->rx_late, (unsigned long long)l->tx_bytes, (unsigned long long)l->tx_undriven,
            (unsigned long long)s->eeprom_writes, (unsigned long long)s->persists,
            (unsigned long long)s->spm_page_ops, (unsigned long long)s->flash_persists,
            (unsigned long long)s->watchdog_resets, s->halted ? ", HALTED" : "");
  }
}

static size_t servo_index_of(const serve_options_t *o, uint8_t id) {
  for (size_t i = 0; i < o->id_count; i++) {
    if (o->ids[i] == id) {
      return i;
    }
  }
  return 0; /* the parser checked every ID against --ids */
}

/* Opens the trace and the gdb port asked for; false with err set. */
static bool debug_open(serve_debug_t *d, world_t *world, const serve_options_t *o, char *err, size_t err_len) {
  memset(d, 0, sizeof(*d));
  if (o->trace_path) {
    bool traced[WORLD_MAX_SERVOS];
    for (size_t i = 0; i < world->servo_count; i++) {
      traced[i] = o->trace_id_count == 0;
    }
    for (size_t i = 0; i < o->trace_id_count; i++) {
      traced[servo_index_of(o, o->trace_ids[i])] = true;
    }
    d->trace = world_trace_open(world, o->trace_path, traced, err, err_len);
    if (!d->trace) {
      return false;
    }
    d->trace_path = o->trace_path;
    d->trace_flush_at_us = pacing_wall_us() + TRACE_FLUSH_PERIOD_US;
  }
  if (o->gdb) {
    servo_t *servo = world->servos[servo_index_of(o, o->gdb_id)];
    if (!servo_gdb_open(&d->gdb, servo, o->gdb_port, err, err_len)) {
      return false;
    }
    d->gdb_open = true;
    world_set_debugged(world, servo);
    fprintf(stderr,
            "ax12-emu: servo %u (%s): gdb on 127.0.0.1:%u: avr-gdb %s -ex 'target remote :%u'; it runs until gdb "
            "attaches; while gdb holds it, the whole bus stands still\n",
            o->gdb_id, servo->name, o->gdb_port, o->elf, o->gdb_port);
  }
  if (d->trace) {
    fprintf(stderr, "ax12-emu: tracing %zu servo%s to %s\n", d->trace->count, d->trace->count == 1 ? "" : "s",
            o->trace_path);
  }
  return true;
}

/* After each run of the world: the trace's events that are final, on disk every
 * TRACE_FLUSH_PERIOD_US; gdb's requests. */
static void debug_after_run(serve_debug_t *d) {
  if (d->trace) {
    world_trace_commit(d->trace);
    const double wall = pacing_wall_us();
    if (wall >= d->trace_flush_at_us) {
      (void)world_trace_flush(d->trace);
      d->trace_flush_at_us = wall + TRACE_FLUSH_PERIOD_US;
    }
  }
  if (d->gdb_open) {
    servo_gdb_poll(&d->gdb, 0);
  }
}

/* While gdb holds the world: serves gdb alone until it lets go or a signal comes; simulated
 * time stands still, so real-time pacing restarts from here afterwards. */
static void debug_wait_while_held(serve_debug_t *d, world_t *world, pacing_t *pacing) {
  if (!d->gdb_open || !world_held(world)) {
    return;
  }
  fprintf(stderr, "ax12-emu: gdb holds %s at pc 0x%04x, %.6f s simulated: the bus stands still\n",
          d->gdb.servo->name, servo_gdb_pc(&d->gdb), sim_cycles_to_us(world->now) / 1e6);
  if (d->trace) {
    (void)world_trace_flush(d->trace);
  }
  while (!stop_requested && world_held(world)) {
    servo_gdb_poll(&d->gdb, GDB_WAIT_US);
  }
  pacing_resume(pacing, world->now);
}

/* Closes the gdb port (a held servo runs on: before the shutdown's settling). */
static void debug_close_gdb(serve_debug_t *d) {
  if (d->gdb_open) {
    servo_gdb_close(&d->gdb);
    d->gdb_open = false;
  }
}

/* Writes the rest of the trace (one line on stderr when `report`); returns false when the
 * file could not be written. */
static bool debug_close_trace(serve_debug_t *d, const world_t *world, bool report) {
  if (!d->trace) {
    return true;
  }
  const unsigned long long changes = d->trace->changes;
  const size_t servos = d->trace->count;
  const int closed = world_trace_close(d->trace);
  d->trace = NULL;
  if (closed != 0) {
    fprintf(stderr, "ax12-emu: the trace %s could not be written whole\n", d->trace_path);
    return false;
  }
  if (!report) {
    return true;
  }
  fprintf(stderr, "ax12-emu: trace %s: %zu servo%s, %.3f s simulated, %llu value changes\n", d->trace_path, servos,
          servos == 1 ? "" : "s", sim_cycles_to_us(world->now) / 1e6, changes);
  return true;
}

static sim_cycles_t sim_of_wall(void *ctx, double wall_us) { return pacing_sim_at(ctx, wall_us); }

static void release_locks(const int *locks, size_t count) {
  for (size_t i = 0; i < count; i++) {
    state_lock_release(locks[i]);
  }
}

/* A state file that holds no valid settings image, or is not an EEPROM of this MCU's size, is
 * kept aside under another name (never overwritten) with a one-line warning; the servo runs on
 * its bytes, so it boots as its firmware decides (factory defaults when no slot is valid),
 * and its state file starts again from them. False (err set) only when that fails. */
static bool check_state_file(servo_t *servo, const char *path, unsigned id, char *err, size_t err_len) {
  char why[160];
  if (eeprom_store_file_fits(path, servo->eeprom_size, why, sizeof why)) {
    if (eeprom_store_image_fields(servo->eeprom, servo->eeprom_size, NULL, NULL)) {
      return true;
    }
    snprintf(why, sizeof why, "no valid settings image");
  }
  char aside[PATH_MAX + 64];
  if (eeprom_store_set_aside(path, aside, sizeof aside) != 0) {
    const int why_not = errno;
    const int n = snprintf(err, err_len, "%s: %s, and it cannot be kept aside: ", path, why);
    if (n >= 0 && (size_t)n < err_len) {
      snprintf(err + n, err_len - (size_t)n, "%s", strerror(why_not));
    }
    return false;
  }
  const bool has_settings = eeprom_store_image_fields(servo->eeprom, servo->eeprom_size, NULL, NULL);
  fprintf(stderr, "ax12-emu: warning: servo %u: %s: %s; kept as %s; the servo boots %s\n", id, path, why, aside,
          has_settings ? "with the settings in it" : "as its firmware decides (factory defaults, ID 1)");
  return eeprom_store_save(path, servo->eeprom, servo->eeprom_size, err, err_len) == 0;
}

/* Where servo `id`'s flash came from, when not from the ELFs alone: one line on stderr. */
static void report_flash_origin(const servo_t *servo, unsigned id, const char *mcu) {
  switch (servo->flash_origin) {
  case SERVO_FLASH_FROM_STATE:
    fprintf(stderr, "ax12-emu: servo %u runs the flash it was updated to (%s)\n", id, servo->flash_path);
    break;
  case SERVO_FLASH_DROPPED_OTHER_BUILD:
    fprintf(stderr, "ax12-emu: the firmware was rebuilt: servo %u's flashed image is dropped (%s removed)\n", id,
            servo->flash_path);
    break;
  case SERVO_FLASH_DROPPED_INVALID:
    fprintf(stderr, "ax12-emu: warning: servo %u: %s is not a flash image of the %s: dropped (removed)\n", id,
            servo->flash_path, mcu);
    break;
  case SERVO_FLASH_FROM_ELF:
    break;
  }
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
  (void)bus_set_noise(&world->bus, o->bit_error_rate, o->noise_seed); /* validated by the parser */
  int locks[ID_LIST_MAX_ID + 1u];
  size_t lock_count = 0;
  for (size_t i = 0; i < o->id_count; i++) {
    char path[PATH_MAX + 32];
    eeprom_store_path(path, sizeof(path), o->state_dir, o->ids[i]);
    const int lock = state_lock_take(path, err, sizeof(err));
    servo_t *servo = lock < 0 ? NULL : world_add_servo(world, o->ids[i], (uint8_t)o->baud, path, err, sizeof(err));
    if (lock >= 0) {
      locks[lock_count++] = lock;
    }
    if (!servo || !check_state_file(servo, path, o->ids[i], err, sizeof(err))) {
      fprintf(stderr, "ax12-emu: servo %u: %s\n", o->ids[i], err);
      release_locks(locks, lock_count);
      world_destroy(world);
      return 1;
    }
    report_flash_origin(servo, o->ids[i], o->mcu);
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
    release_locks(locks, lock_count);
    world_destroy(world);
    return 1;
  }
  emu_bus_log_t bus_logging;
  if (emu_bus_log_start(&bus_logging, o->log_bus, &world->bus, pty.node, err, sizeof(err)) != 0) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    pty_bridge_close(&pty);
    release_locks(locks, lock_count);
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
      release_locks(locks, lock_count);
      world_destroy(world);
      return 1;
    }
    if (!control_open) {
      fprintf(stderr, "ax12-emu: warning: %s; running without a control socket (give one with --control)\n", err);
    }
  } else if (o->control_explicit) {
    fprintf(stderr, "ax12-emu: --control: the path is too long\n");
  }
  emu_dashboard_t dashboard = {0};
  if (o->dashboard) {
    if (!control_open || emu_dashboard_start(&dashboard, o->control_path, o->dashboard, err, sizeof(err)) != 0) {
      fprintf(stderr, "ax12-emu: --dashboard: %s\n", control_open ? err : "it needs the control socket");
      if (control_open) {
        emu_control_close(&control);
      }
      (void)emu_bus_log_stop(&bus_logging, false);
      pty_bridge_close(&pty);
      release_locks(locks, lock_count);
      world_destroy(world);
      return 1;
    }
    fprintf(stderr, "ax12-emu: dashboard at %s\n", dashboard.url);
  }

  serve_debug_t debug;
  if (!debug_open(&debug, world, o, err, sizeof(err))) {
    fprintf(stderr, "ax12-emu: %s\n", err);
    debug_close_gdb(&debug);
    (void)debug_close_trace(&debug, world, false);
    pty_bridge_close(&pty);
    release_locks(locks, lock_count);
    world_destroy(world);
    return 1;
  }

  struct sigaction sa;
  memset(&sa, 0, sizeof(sa));
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, NULL);
  sigaction(SIGTERM, &sa, NULL);
  sigaction(SIGHUP, &sa, NULL);
  signal(SIGPIPE, SIG_IGN);

  pacing_t pacing;
  pacing_start(&pacing, o->realtime, world->now);
  const sim_cycles_t slice = sim_us(SLICE_US);

  /* Boot: until every servo listens on the bus. */
  bool booted = false;
  while (!stop_requested && world->now < sim_ms(BOOT_LIMIT_MS)) {
    debug_wait_while_held(&debug, world, &pacing);
    booted = true;
    for (size_t i = 0; i < world->servo_count; i++) {
      booted &= servo_listening(world->servos[i]);
    }
    if (booted) {
      break;
    }
    world_run_until(world, world->now + slice);
    debug_after_run(&debug);
    (void)pacing_wait(&pacing, world->now, -1);
  }
  if (!booted && !stop_requested) {
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
  while (!stop_requested) {
    debug_wait_while_held(&debug, world, &pacing);
    if (stop_requested) {
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
    debug_after_run(&debug);
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
  debug_close_gdb(&debug);
  const int failures = world_settle_and_persist(world, sim_ms(SHUTDOWN_SETTLE_MS));
  const bool traced = debug_close_trace(&debug, world, true);
  if (failures) {
    for (size_t i = 0; i < world->servo_count; i++) {
      if (world->servos[i]->persist_errors) {
        fprintf(stderr, "ax12-emu: %s: %s\n", world->servos[i]->name, world->servos[i]->last_error);
      }
    }
  }
  if (o->stats) {
    print_stats(world, &pty, &pacing);
  }
  const int log_failed = emu_bus_log_stop(&bus_logging, o->stats);
  pty_bridge_close(&pty);
  world_destroy(world);
  release_locks(locks, lock_count); /* after the last state file was written */
  return failures || log_failed || !traced ? 1 : 0;
}

