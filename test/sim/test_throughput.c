/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Sustained bus load through the firmware ELF: 30 servos at 1 Mbps, the master sending
 * SYNC_WRITE packets (Goal Position + Moving Speed for every servo, 158 bytes) back to back
 * for THROUGHPUT_SECONDS of simulated time. Every servo must take every byte (no byte lost
 * to a full ring or to the USART, no line error), keep its 1 kHz timebase and control tick
 * running, and hold the values of the last packet afterwards. */
#include <gelf.h>
#include <libelf.h>

#include <fcntl.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>
#include <sim_avr.h>

#include "dxl_protocol.h"
#include "dxl_table.h"
#include "elf_symbols.h"
#include "sim_harness.h"

#define SERVO_COUNT 30u
/* Length of the load, simulated. */
#define THROUGHPUT_SECONDS 2u
#define SYNC_WRITE_DATA_LEN 4u /* Goal Position L/H, Moving Speed L/H */
/* params: start address, data length, then ID + data per servo. */
#define SYNC_WRITE_PARAMS (2u + SERVO_COUNT * (1u + SYNC_WRITE_DATA_LEN))
#define SYNC_WRITE_PACKET_LEN (SYNC_WRITE_PARAMS + 6u) /* 158 bytes */
/* Control ticks may lag the millisecond count by at most this many per second. */
#define CONTROL_TICKS_SLACK_PER_S 5u
/* Timebase ticks may differ from the elapsed milliseconds by this many. */
#define TIMEBASE_TOLERANCE_MS 2
/* Silence on the bus between the load and the read-back. */
#define QUIET_AFTER_LOAD_MS 5u
#define STATUS_LEN(params) (6u + (params))
/* One 8N1 byte at 1 Mbps: 10 bits of 1 us. */
#define BYTE_CYCLES_AT_1_MBPS (10u * SIM_CYCLES_PER_US)

/* Goal Position and Moving Speed that packet number `packet` (0, 1, ...) gives servo `id`.
 * Both change from one packet to the next (steps of 37 and 11, never 0 mod 1024) and stay in
 * 0..1023: inside the default angle limits (CW 0, CCW 1023) and the speed range. */
static uint16_t goal_position(unsigned packet, uint8_t id) { return (uint16_t)((packet * 37u + id * 29u) % 1024u); }
static uint16_t moving_speed(unsigned packet, uint8_t id) { return (uint16_t)((packet * 11u + id * 53u) % 1024u); }

/* The 4 data bytes of servo id in packet number `packet`, as the control table holds them
 * from address 30: Goal Position L, H, Moving Speed L, H. */
static void goal_and_speed_bytes(unsigned packet, uint8_t id, uint8_t out[SYNC_WRITE_DATA_LEN]) {
  const uint16_t goal = goal_position(packet, id);
  const uint16_t speed = moving_speed(packet, id);
  out[0] = (uint8_t)(goal & 0xFFu);
  out[1] = (uint8_t)(goal >> 8);
  out[2] = (uint8_t)(speed & 0xFFu);
  out[3] = (uint8_t)(speed >> 8);
}

/* Broadcast SYNC_WRITE number `packet` to IDs 1..SERVO_COUNT into out; returns its size
 * (SYNC_WRITE_PACKET_LEN). */
static size_t build_sync_write(unsigned packet, uint8_t out[SYNC_WRITE_PACKET_LEN]) {
  uint8_t params[SYNC_WRITE_PARAMS];
  params[0] = CT_ADDR_GOAL_POSITION;
  params[1] = SYNC_WRITE_DATA_LEN;
  for (uint8_t id = 1; id <= SERVO_COUNT; id++) {
    uint8_t *slot = &params[2u + (id - 1u) * (1u + SYNC_WRITE_DATA_LEN)];
    slot[0] = id;
    goal_and_speed_bytes(packet, id, &slot[1]);
  }
  return packet_encode(out, DXL_ID_BROADCAST, DXL_INST_SYNC_WRITE, params, sizeof(params));
}

/* ---- Firmware RAM counters, found by symbol in the ELF. ---- */

/* Size in bytes of the ELF symbol `name` (st_size), 0 when it is not there. */
static unsigned elf_symbol_size(const char *elf_path, const char *name) {
  unsigned size = 0;
  const int fd = open(elf_path, O_RDONLY | O_CLOEXEC);
  if (fd < 0 || elf_version(EV_CURRENT) == EV_NONE) {
    if (fd >= 0) {
      close(fd);
    }
    return 0;
  }
  Elf *elf = elf_begin(fd, ELF_C_READ, NULL);
  Elf_Scn *scn = NULL;
  while (elf && size == 0 && (scn = elf_nextscn(elf, scn)) != NULL) {
    GElf_Shdr shdr;
    if (!gelf_getshdr(scn, &shdr) || shdr.sh_type != SHT_SYMTAB || shdr.sh_entsize == 0) {
      continue;
    }
    Elf_Data *data = elf_getdata(scn, NULL);
    for (size_t i = 0; data && i < shdr.sh_size / shdr.sh_entsize; i++) {
      GElf_Sym sym;
      const char *sym_name = gelf_getsym(data, (int)i, &sym) ? elf_strptr(elf, shdr.sh_link, sym.st_name) : NULL;
      if (sym_name && strcmp(sym_name, name) == 0) {
        size = (unsigned)sym.st_size;
        break;
      }
    }
  }
  if (elf) {
    elf_end(elf);
  }
  close(fd);
  return size;
}

/* An unsigned little-endian counter in the firmware's RAM. Its width comes from the ELF, so
 * a counter widened by the firmware is still read whole. */
typedef struct {
  const char *symbol;
  uint32_t address; /* RAM address */
  unsigned size;    /* bytes: 1, 2 or 4 */
} firmware_counter_t;

static firmware_counter_t firmware_counter(const char *elf_path, const char *symbol) {
  firmware_counter_t c = {.symbol = symbol};
  if (!elf_symbol_address(elf_path, symbol, &c.address)) {
    fail_msg("the firmware ELF %s has no symbol %s", elf_path, symbol);
  }
  c.size = elf_symbol_size(elf_path, symbol);
  if (c.size != 1u && c.size != 2u && c.size != 4u) {
    fail_msg("%s: %u bytes, expected an 8, 16 or 32-bit counter", symbol, c.size);
  }
  return c;
}

static uint32_t counter_value(const firmware_counter_t *c, const servo_t *s) {
  uint32_t value = 0;
  for (unsigned i = 0; i < c->size; i++) {
    value |= (uint32_t)s->avr->data[c->address + i] << (8u * i);
  }
  return value;
}

/* How far the counter advanced from `before` to `after`, modulo its width. */
static uint32_t counter_advance(const firmware_counter_t *c, uint32_t before, uint32_t after) {
  const uint32_t mask = c->size >= 4u ? UINT32_MAX : (UINT32_C(1) << (8u * c->size)) - 1u;
  return (after - before) & mask;
}

typedef struct {
  firmware_counter_t rx_dropped;     /* bytes lost to a full RX ring (saturates) */
  firmware_counter_t rx_line_errors; /* frame / overrun errors the RX ISR saw (saturates) */
  firmware_counter_t control_ticks;  /* control ticks the main loop ran */
  firmware_counter_t timebase_ms;    /* 1 ms timer interrupts */
} firmware_counters_t;

static firmware_counters_t find_firmware_counters(const char *elf_path) {
  return (firmware_counters_t){
      .rx_dropped = firmware_counter(elf_path, "uart_rx_dropped_count"),
      .rx_line_errors = firmware_counter(elf_path, "uart_rx_line_error_count"),
      .control_ticks = firmware_counter(elf_path, "control_tick_count"),
      .timebase_ms = firmware_counter(elf_path, "timebase_ms_count"),
  };
}

/* What one servo's counters read at one moment. */
typedef struct {
  uint32_t control_ticks;
  uint32_t timebase_ms;
} servo_ticks_t;

static servo_ticks_t read_ticks(const firmware_counters_t *fc, const servo_t *s) {
  return (servo_ticks_t){
      .control_ticks = counter_value(&fc->control_ticks, s),
      .timebase_ms = counter_value(&fc->timebase_ms, s),
  };
}

/* ---- The load. ---- */

typedef struct {
  unsigned packets;
  size_t bytes;
  sim_cycles_t start, end; /* first start bit, last stop bit's end */
} traffic_t;

/* Sends SYNC_WRITE packets back to back from now, each starting where the previous one's
 * last stop bit ends, for as long as a packet would start within `duration`; returns when
 * the last one has ended. Host nodes may only send between world steps, so the next packet
 * is queued while the current one is on the wire. */
static traffic_t send_back_to_back(harness_t *h, sim_cycles_t duration, bool garbage) {
  traffic_t t = {.start = h->world->now};
  uint8_t packet[SYNC_WRITE_PACKET_LEN + 1];
  for (;;) {
    const sim_cycles_t packet_start = h->master->tx_end > h->world->now ? h->master->tx_end : h->world->now;
    if (packet_start >= t.start + duration) {
      break;
    }
    size_t n = build_sync_write(t.packets, packet);
    if (garbage) { /* one byte more than LENGTH says, before the checksum: a bad checksum */
      packet[n] = packet[n - 1u];
      packet[n - 1u] = 0x55;
      n++;
    }
    master_send(h->master, packet, n);
    t.packets++;
    t.bytes += n;
    world_run_until(h->world, packet_start); /* the packet before has ended */
  }
  t.end = h->master->tx_end;
  world_run_until(h->world, t.end);
  return t;
}

/* ---- The test. ---- */

static void open_bus_of_30(harness_t *h) {
  harness_open(h, "ax12", "atmega88", 1); /* master at 1 Mbps */
  for (uint8_t id = 1; id <= SERVO_COUNT; id++) {
    harness_add_servo(h, id, 1, NULL);
  }
  harness_boot(h, 20);
}

static void expect_reply(const uint8_t *got, size_t got_len, uint8_t id, const uint8_t *params, size_t count) {
  uint8_t want[64];
  const size_t want_len = packet_encode(want, id, 0, params, count); /* error byte 0 */
  if (got_len != want_len || memcmp(got, want, want_len) != 0) {
    char a[256];
    char b[256];
    fail_msg("servo %u: expected %s, heard %s", id, packet_hex(want, want_len, a, sizeof(a)),
             packet_hex(got, got_len, b, sizeof(b)));
  }
}

/* No byte lost, no line error, no overrun in the USART model, since power-up. */
static void expect_no_lost_bytes(const harness_t *h, const firmware_counters_t *fc) {
  for (size_t i = 0; i < h->world->servo_count; i++) {
    const servo_t *s = h->world->servos[i];
    if (counter_value(&fc->rx_dropped, s) != 0 || counter_value(&fc->rx_line_errors, s) != 0 ||
        s->board.link.rx_overruns != 0) {
      fail_msg("%s: %u bytes dropped by the firmware, %u line errors, %llu USART overruns", s->name,
               counter_value(&fc->rx_dropped, s), counter_value(&fc->rx_line_errors, s),
               (unsigned long long)s->board.link.rx_overruns);
    }
  }
}

/* The figures of the load over all servos, for the summary line. */
typedef struct {
  uint32_t fewest_control_ticks, most_control_ticks;
  uint32_t fewest_timebase_ms, most_timebase_ms;
  unsigned long rx_dropped, rx_line_errors; /* firmware counters, summed */
  unsigned long long rx_overruns;           /* USART model (uart_link_t), summed */
} load_figures_t;

static load_figures_t measure_load(const harness_t *h, const firmware_counters_t *fc, const servo_ticks_t *before) {
  load_figures_t f = {.fewest_control_ticks = UINT32_MAX, .fewest_timebase_ms = UINT32_MAX};
  for (size_t i = 0; i < h->world->servo_count; i++) {
    const servo_t *s = h->world->servos[i];
    const servo_ticks_t after = read_ticks(fc, s);
    const uint32_t control = counter_advance(&fc->control_ticks, before[i].control_ticks, after.control_ticks);
    const uint32_t ms = counter_advance(&fc->timebase_ms, before[i].timebase_ms, after.timebase_ms);
    f.fewest_control_ticks = control < f.fewest_control_ticks ? control : f.fewest_control_ticks;
    f.most_control_ticks = control > f.most_control_ticks ? control : f.most_control_ticks;
    f.fewest_timebase_ms = ms < f.fewest_timebase_ms ? ms : f.fewest_timebase_ms;
    f.most_timebase_ms = ms > f.most_timebase_ms ? ms : f.most_timebase_ms;
    f.rx_dropped += counter_value(&fc->rx_dropped, s);
    f.rx_line_errors += counter_value(&fc->rx_line_errors, s);
    f.rx_overruns += s->board.link.rx_overruns;
  }
  return f;
}

/* One line for the CI log, printed before the checks so a failure shows its numbers. */
static void print_summary(const traffic_t *t, const load_figures_t *f) {
  printf("sim_throughput: %u servos at 1 Mbps, %u SYNC_WRITE packets, %zu bytes back to back in %.6f s simulated; "
         "control ticks %u..%u (worst %u), timebase %u..%u ms; bytes dropped %lu, line errors %lu, "
         "USART overruns %llu\n",
         SERVO_COUNT, t->packets, t->bytes, sim_cycles_to_us(t->end - t->start) / 1e6, f->fewest_control_ticks,
         f->most_control_ticks, f->fewest_control_ticks, f->fewest_timebase_ms, f->most_timebase_ms, f->rx_dropped,
         f->rx_line_errors, f->rx_overruns);
  fflush(stdout);
}

/* Every servo's timebase advanced by the elapsed milliseconds (+- TIMEBASE_TOLERANCE_MS) and
 * its control loop by at least CONTROL_TICKS_SLACK_PER_S per second fewer. */
static void expect_ticks_kept_up(const harness_t *h, const firmware_counters_t *fc, const servo_ticks_t *before,
                                 sim_cycles_t elapsed) {
  const long elapsed_ms = (long)((elapsed + sim_ms(1) / 2u) / sim_ms(1));
  const uint32_t min_control = (uint32_t)(elapsed_ms - elapsed_ms * (long)CONTROL_TICKS_SLACK_PER_S / 1000);
  for (size_t i = 0; i < h->world->servo_count; i++) {
    const servo_t *s = h->world->servos[i];
    const servo_ticks_t after = read_ticks(fc, s);
    const long ms = (long)counter_advance(&fc->timebase_ms, before[i].timebase_ms, after.timebase_ms);
    const uint32_t control = counter_advance(&fc->control_ticks, before[i].control_ticks, after.control_ticks);
    if (ms < elapsed_ms - TIMEBASE_TOLERANCE_MS || ms > elapsed_ms + TIMEBASE_TOLERANCE_MS) {
      fail_msg("%s: timebase advanced %ld ms in %ld ms of simulated time", s->name, ms, elapsed_ms);
    }
    if (control < min_control) {
      fail_msg("%s: %u control ticks in %ld ms, at least %u expected", s->name, control, elapsed_ms, min_control);
    }
  }
}

/* Every servo holds the Goal Position and Moving Speed of packet number `last_packet`. */
static void expect_last_packet_applied(harness_t *h, unsigned last_packet) {
  for (uint8_t id = 1; id <= SERVO_COUNT; id++) {
    uint8_t want[SYNC_WRITE_DATA_LEN];
    goal_and_speed_bytes(last_packet, id, want);
    uint8_t reply[HARNESS_MAX_REPLY];
    const size_t n =
        harness_request(h, id, DXL_INST_READ, HP(CT_ADDR_GOAL_POSITION, SYNC_WRITE_DATA_LEN), STATUS_LEN(4), reply);
    expect_reply(reply, n, id, want, sizeof(want));
  }
}

static void expect_every_servo_answers_ping(harness_t *h) {
  for (uint8_t id = 1; id <= SERVO_COUNT; id++) {
    uint8_t reply[HARNESS_MAX_REPLY];
    const size_t n = harness_request(h, id, DXL_INST_PING, H_NO_PARAMS, STATUS_LEN(0), reply);
    expect_reply(reply, n, id, H_NO_PARAMS);
  }
}

/* The bus of 30, its firmware counters, and every servo's counts before the load. */
static void open_bus_of_30_and_count(harness_t *h, firmware_counters_t *fc, servo_ticks_t before[SERVO_COUNT]) {
  open_bus_of_30(h);
  *fc = find_firmware_counters(h->elf);
  for (size_t i = 0; i < SERVO_COUNT; i++) {
    before[i] = read_ticks(fc, h->world->servos[i]);
  }
  master_rx_clear(h->master);
}

static void test_30_servos_at_1_mbps_keep_up_with_back_to_back_sync_writes(void **state) {
  (void)state;
  harness_t h;
  firmware_counters_t fc;
  servo_ticks_t before[SERVO_COUNT];
  open_bus_of_30_and_count(&h, &fc, before);

  const traffic_t t = send_back_to_back(&h, sim_ms(THROUGHPUT_SECONDS * 1000u), false);

  const load_figures_t figures = measure_load(&h, &fc, before);
  print_summary(&t, &figures);

  /* The wire was never idle: the packets took exactly their bytes' frame time. */
  assert_int_equal(t.end - t.start, (sim_cycles_t)t.bytes * BYTE_CYCLES_AT_1_MBPS);
  /* Nobody answered a broadcast. */
  assert_int_equal(master_rx_count(h.master), 0);
  expect_no_lost_bytes(&h, &fc);
  expect_ticks_kept_up(&h, &fc, before, t.end - t.start);

  /* The bus is quiet from here on: the final packet took effect everywhere. */
  world_run_until(h.world, h.world->now + sim_ms(QUIET_AFTER_LOAD_MS));
  expect_last_packet_applied(&h, t.packets - 1u);
  expect_every_servo_answers_ping(&h);
  expect_no_lost_bytes(&h, &fc);
  harness_close(&h);
}

/* Back-to-back packets whose checksum is wrong (one byte more than their LENGTH) for
 * GARBAGE_MS: the finder rejects each one and rescans it byte by byte. It keeps up as with
 * good packets: no byte lost, every control tick run, the timebase exact; and once the line
 * is quiet every servo answers again. */
#define GARBAGE_MS 500u
#define RESYNC_QUIET_MS 120u /* past the finder's 100 ms gap rule */

static void test_a_garbage_flood_at_1_mbps_loses_no_byte_and_no_tick(void **state) {
  (void)state;
  harness_t h;
  firmware_counters_t fc;
  servo_ticks_t before[SERVO_COUNT];
  open_bus_of_30_and_count(&h, &fc, before);
  const traffic_t t = send_back_to_back(&h, sim_ms(GARBAGE_MS), true);
  const load_figures_t figures = measure_load(&h, &fc, before);
  printf("garbage: ");
  print_summary(&t, &figures);
  expect_no_lost_bytes(&h, &fc);
  expect_ticks_kept_up(&h, &fc, before, t.end - t.start);
  world_run_until(h.world, h.world->now + sim_ms(RESYNC_QUIET_MS));
  expect_every_servo_answers_ping(&h);
  harness_close(&h);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_30_servos_at_1_mbps_keep_up_with_back_to_back_sync_writes),
      cmocka_unit_test(test_a_garbage_flood_at_1_mbps_loses_no_byte_and_no_tick),
  };
  return cmocka_run_group_tests_name("sim throughput (firmware ELF)", tests, NULL, NULL);
}
