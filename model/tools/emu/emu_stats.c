/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_stats.h"

#include <stdio.h>

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

/* The start-up and the delays of real time (pty_bridge.h): the client's bytes to the bus, the
 * adapter's hand-overs to the pty, the lag, the pacing thread's yields and drops of its
 * scheduling policy, and that policy. */
static void print_timing(const pty_bridge_t *pty, const pacing_t *pacing, const emu_realtime_t *rt) {
  const delay_histogram_t *in = &pty->to_bus_delay;
  fprintf(stderr,
          "ax12-emu: timing: boot %.1f ms simulated in %.1f ms, warm-up %.1f ms; client to bus delay p50 %.3f / "
          "p99 %.3f / max %.3f ms over %llu writes (the pty reader's wait for a CPU at most %.3f ms)",
          rt->boot_sim_us / 1e3, rt->boot_wall_us / 1e3, rt->warm_wall_us / 1e3,
          delay_histogram_quantile_us(in, 0.5) / 1e3, delay_histogram_quantile_us(in, 0.99) / 1e3, in->max_us / 1e3,
          (unsigned long long)in->count, pty->reader_wait_max_us / 1e3);
  if (pacing->realtime) {
    const delay_histogram_t *out = &pty->to_client_late;
    fprintf(stderr,
            "; hand-overs to the client late p50 %.3f / p99 %.3f / max %.3f ms over %llu; worst lag %.3f ms; "
            "behind real time: %llu yields of the CPU, the policy dropped %llu times (%.1f s)",
            delay_histogram_quantile_us(out, 0.5) / 1e3, delay_histogram_quantile_us(out, 0.99) / 1e3,
            out->max_us / 1e3, (unsigned long long)out->count, pacing->max_behind_us / 1e3,
            (unsigned long long)pacing->rt.yields, (unsigned long long)pacing->rt.drops, pacing->rt.dropped_us / 1e6);
  }
  char policy[sizeof(rt->why_not) + 64];
  emu_realtime_describe(rt, policy, sizeof(policy));
  fprintf(stderr, "; scheduling: %s\n", policy);
}

void emu_stats_print(const world_t *world, const pty_bridge_t *pty, const pacing_t *pacing,
                     const emu_realtime_t *rt) {
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
  print_timing(pty, pacing, rt);
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
