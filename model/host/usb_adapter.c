/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "usb_adapter.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const usb_adapter_chip_t chips[] = {
    [USB_ADAPTER_WIRE] = {.name = "wire", .chip = "none"},
    /* FT232H datasheet: high-speed bulk packets of 512 B, 1 KB buffers; 12 MHz baud base with
     * the divide-by-2.5 off (Linux ftdi_2232h_baud_base_to_divisor), 12 MBaud at most. */
    [USB_ADAPTER_U2D2] = {.name = "u2d2", .chip = "FT232H class", .packet_bytes = 512u, .status_bytes = 2u,
                          .frame_ns = 125000u, .to_bus_buffer_bytes = 1024u, .to_host_buffer_bytes = 1024u,
                          .baud_base_hz = 12e6, .max_bps = 12e6},
    /* FT232R datasheet: full-speed packets of 64 B, 256 B host-to-UART and 128 B UART-to-host
     * buffers; 3 MHz baud base (48 MHz / 16), 3 MBaud at most. */
    [USB_ADAPTER_USB2DYNAMIXEL] = {.name = "usb2dynamixel", .chip = "FT232R", .packet_bytes = 64u, .status_bytes = 2u,
                                   .frame_ns = 1000000u, .to_bus_buffer_bytes = 256u, .to_host_buffer_bytes = 128u,
                                   .baud_base_hz = 3e6, .max_bps = 3e6},
};

const usb_adapter_chip_t *usb_adapter_chip(usb_adapter_kind_t kind) {
  return &chips[(unsigned)kind < sizeof(chips) / sizeof(chips[0]) ? kind : USB_ADAPTER_WIRE];
}

bool usb_adapter_parse(const char *text, usb_adapter_config_t *config, char *err, size_t err_len) {
  const char *colon = strchr(text, ':');
  const size_t name_len = colon ? (size_t)(colon - text) : strlen(text);
  for (unsigned k = 0; k < sizeof(chips) / sizeof(chips[0]); k++) {
    if (strlen(chips[k].name) != name_len || strncmp(text, chips[k].name, name_len) != 0) {
      continue;
    }
    usb_adapter_config_t c = {.kind = (usb_adapter_kind_t)k, .latency_ms = USB_ADAPTER_DEFAULT_LATENCY_MS};
    if (colon) {
      if (c.kind == USB_ADAPTER_WIRE) {
        snprintf(err, err_len, "the wire adapter has no latency timer ('%s')", text);
        return false;
      }
      const char *value = colon + 1;
      char *end = NULL;
      errno = 0;
      const unsigned long ms = strtoul(value, &end, 10);
      if (value[0] < '0' || value[0] > '9' || errno || !end || *end || ms < USB_ADAPTER_LATENCY_MIN_MS ||
          ms > USB_ADAPTER_LATENCY_MAX_MS) {
        snprintf(err, err_len, "bad latency timer in '%s': whole milliseconds %u..%u", text,
                 USB_ADAPTER_LATENCY_MIN_MS, USB_ADAPTER_LATENCY_MAX_MS);
        return false;
      }
      c.latency_ms = (unsigned)ms;
    }
    *config = c;
    return true;
  }
  snprintf(err, err_len, "unknown adapter '%s' (u2d2[:MS], usb2dynamixel[:MS] or wire)", text);
  return false;
}

void usb_adapter_describe(const usb_adapter_config_t *config, char *out, size_t out_len) {
  const usb_adapter_chip_t *chip = usb_adapter_chip(config->kind);
  if (config->kind == USB_ADAPTER_WIRE) {
    snprintf(out, out_len, "wire");
  } else {
    snprintf(out, out_len, "%s:%u (%s, latency timer %u ms)", chip->name, config->latency_ms, chip->chip,
             config->latency_ms);
  }
}

/* The chip's rate for a divisor in eighths of its base (divisor3 >= 8): FTDI's sub-integer
 * divisors below 2 are only 1 (base) and 1.5 (base / 1.5); the others between 1 and 2 are not
 * allowed (FTDI AN232B-05), so a request landing there takes the nearest allowed one (a tie
 * the slower). */
static double rate_of_eighths(double base_hz, long divisor3) {
  if (divisor3 < 16) {
    divisor3 = divisor3 <= 9 ? 8 : divisor3 <= 13 ? 12 : 16;
  }
  if (divisor3 > 0x1FFFF) {
    divisor3 = 0x1FFFF; /* 17 bits: ~183 baud on a 3 MHz base */
  }
  return base_hz * 8.0 / (double)divisor3;
}

double usb_adapter_actual_bps(usb_adapter_kind_t kind, double requested_bps) {
  const usb_adapter_chip_t *chip = usb_adapter_chip(kind);
  if (kind == USB_ADAPTER_WIRE || requested_bps <= 0.0) {
    return requested_bps;
  }
  if (requested_bps > chip->max_bps) {
    requested_bps = 9600.0; /* ftdi_sio: "Baud rate too high!", 9600 instead */
  }
  double base = chip->baud_base_hz;
  if (kind == USB_ADAPTER_U2D2 && requested_bps < 1200.0) {
    base = 3e6; /* ftdi_sio uses the 3 MHz divisor below 1200 baud on hi-speed chips */
  }
  return rate_of_eighths(base, lround(base * 8.0 / requested_bps));
}

void usb_adapter_init(usb_adapter_t *a, const usb_adapter_config_t *config, sim_cycles_t start) {
  memset(a, 0, sizeof(*a));
  a->config = *config;
  a->chip = usb_adapter_chip(config->kind);
  if (config->kind != USB_ADAPTER_WIRE) {
    a->latency_cycles = sim_ms(config->latency_ms);
    a->frame_cycles = (sim_cycles_t)a->chip->frame_ns * SIM_CYCLES_PER_US / 1000u;
    a->payload_bytes = a->chip->packet_bytes - a->chip->status_bytes;
  }
  a->timer_start = start;
}

static void emit(usb_adapter_t *a, sim_cycles_t at, uint32_t bytes) {
  if (a->ring_count == USB_ADAPTER_PACKET_RING) {
    abort(); /* the caller did not pop (contract) */
  }
  a->ring[(a->ring_head + a->ring_count) % USB_ADAPTER_PACKET_RING] = (usb_adapter_packet_t){.at = at, .bytes = bytes};
  a->ring_count++;
  a->stats.in_packets++;
  a->stats.in_bytes += bytes;
  if (bytes > a->stats.max_in_bytes) {
    a->stats.max_in_bytes = bytes;
  }
}

void usb_adapter_advance(usb_adapter_t *a, sim_cycles_t t) {
  if (a->config.kind == USB_ADAPTER_WIRE || t < a->timer_start) {
    return;
  }
  const sim_cycles_t period = a->latency_cycles;
  if (a->held) {
    /* The held bytes came after timer_start: they leave at its next expiry. */
    const sim_cycles_t expiry = a->timer_start + period;
    if (expiry > t) {
      return;
    }
    const sim_cycles_t wait = expiry - a->last_end;
    a->stats.latency_wait_total += wait;
    if (wait > a->stats.latency_wait_max) {
      a->stats.latency_wait_max = wait;
    }
    a->stats.in_timer_packets++;
    emit(a, expiry, a->held);
    a->held = 0;
    a->timer_start = expiry;
  }
  /* Nothing held: each expiry up to t sends the status bytes alone and restarts the timer. */
  const sim_cycles_t expiries = (t - a->timer_start) / period;
  a->stats.in_status_only += expiries;
  a->timer_start += expiries * period;
}

void usb_adapter_rx_byte(usb_adapter_t *a, sim_cycles_t end) {
  if (a->config.kind == USB_ADAPTER_WIRE) {
    emit(a, end, 1u);
    return;
  }
  usb_adapter_advance(a, end);
  a->held++;
  a->last_end = end;
  if (a->held > a->stats.held_max) {
    a->stats.held_max = a->held;
  }
  if (a->held == a->payload_bytes) {
    a->stats.in_full_packets++;
    emit(a, end, a->held);
    a->held = 0;
    a->timer_start = end; /* a packet went to the host: the timer restarts */
  }
}

bool usb_adapter_pop(usb_adapter_t *a, usb_adapter_packet_t *packet) {
  if (!a->ring_count) {
    return false;
  }
  *packet = a->ring[a->ring_head];
  a->ring_head = (a->ring_head + 1u) % USB_ADAPTER_PACKET_RING;
  a->ring_count--;
  return true;
}

sim_cycles_t usb_adapter_next_release(const usb_adapter_t *a) {
  if (a->config.kind == USB_ADAPTER_WIRE || !a->held) {
    return SIM_CYCLES_NEVER;
  }
  return a->timer_start + a->latency_cycles;
}

sim_cycles_t usb_adapter_tx_write(usb_adapter_t *a, sim_cycles_t arrival, uint32_t bytes) {
  a->stats.out_writes++;
  a->stats.out_bytes += bytes;
  if (a->config.kind == USB_ADAPTER_WIRE) {
    return arrival;
  }
  a->stats.out_packets += (bytes + a->chip->packet_bytes - 1u) / a->chip->packet_bytes;
  const sim_cycles_t frame = a->frame_cycles;
  const sim_cycles_t start = (arrival + frame - 1u) / frame * frame;
  a->stats.frame_wait_total += start - arrival;
  return start;
}

uint32_t usb_adapter_tx_queue_limit(const usb_adapter_t *a) {
  if (a->config.kind == USB_ADAPTER_WIRE) {
    return 0;
  }
  return USB_ADAPTER_HOST_WRITE_FIFO_BYTES + a->chip->to_bus_buffer_bytes;
}
