/* SPDX-License-Identifier: MIT */
/* The bus monitor (model/bus/bus_monitor.c) on the wire model alone, no simavr: packets
 * assembled byte by byte from the bus's tap, garbage and resynchronisation, checksums,
 * collisions, two senders, status packets, Protocol 2.0 frames, the gap, the listeners and the
 * CSV line. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "bus.h"
#include "bus_monitor.h"
#include "bus_packet_text.h"
#include "packet_encode.h"

#define CYCLES_1MBPS 16.0
#define BYTE_CYCLES 160u
#define GAP_CYCLES sim_us(BUS_MONITOR_DEFAULT_GAP_US)
#define MAX_RECORDS 32u

/* A record as a listener saw it, copied out of the call. */
typedef struct {
  bus_packet_t p;
  char sender[32];
  uint8_t params[256];
  uint8_t raw[BUS_MONITOR_MAX_RAW];
  char csv[BUS_PACKET_CSV_MAX];
} seen_t;

typedef struct {
  seen_t r[MAX_RECORDS];
  size_t count;
} log_t;

static void keep(void *ctx, const bus_packet_t *p) {
  log_t *log = ctx;
  assert_true(log->count < MAX_RECORDS);
  seen_t *s = &log->r[log->count++];
  s->p = *p;
  snprintf(s->sender, sizeof(s->sender), "%s", p->sender_name);
  if (p->param_count) {
    memcpy(s->params, p->params, p->param_count);
  }
  memcpy(s->raw, p->raw, p->raw_count);
  s->p.params = s->params;
  s->p.raw = s->raw;
  s->p.sender_name = s->sender;
  bus_packet_csv(p, s->csv, sizeof(s->csv));
}

static double node_cycles_per_bit(void *ctx) {
  (void)ctx;
  return CYCLES_1MBPS;
}

static void node_deliver(void *ctx, const bus_rx_t *rx) {
  (void)ctx;
  (void)rx;
}

/* A bus with a client ("pty", node 0) and two servos (nodes 1, 2), a monitor and a log. */
typedef struct {
  bus_t bus;
  bus_monitor_t *mon;
  log_t log;
  int client, servo1, servo2;
} rig_t;

static rig_t *rig_new(void) {
  rig_t *r = test_calloc(1, sizeof(*r));
  bus_init(&r->bus);
  const bus_node_ops_t ops = {.cycles_per_bit = node_cycles_per_bit, .deliver = node_deliver, .ctx = NULL};
  r->client = bus_add_node(&r->bus, "pty", &ops);
  r->servo1 = bus_add_node(&r->bus, "servo-1", &ops);
  r->servo2 = bus_add_node(&r->bus, "servo-2", &ops);
  r->mon = bus_monitor_create(&r->bus, GAP_CYCLES);
  assert_non_null(r->mon);
  bus_monitor_set_client(r->mon, r->client);
  assert_int_equal(bus_monitor_add_listener(r->mon, keep, &r->log), 0);
  return r;
}

static void rig_free(rig_t *r) {
  bus_monitor_destroy(r->mon);
  assert_null(r->bus.tap);
  bus_free(&r->bus);
  test_free(r);
}

/* Node sends bytes on the bus from `start`, back to back; finalized at once. Returns the end. */
static sim_cycles_t send(rig_t *r, int node, const uint8_t *bytes, size_t count, sim_cycles_t start) {
  sim_cycles_t end = start;
  for (size_t i = 0; i < count; i++) {
    end = bus_send(&r->bus, node, bytes[i], i ? end : start);
  }
  bus_finalize(&r->bus, end);
  return end;
}

/* Feeds one byte to the monitor directly (for exact timings). */
static void feed(rig_t *r, int node, uint8_t value, sim_cycles_t start) {
  const bus_tap_byte_t b = {
      .start = start, .end = start + BYTE_CYCLES, .sent = value, .wire = value, .flags = 0, .sender = (uint8_t)node};
  bus_monitor_byte(r->mon, &b);
}

static void assert_record(const seen_t *s, bus_packet_kind_t kind, const char *sender, const char *raw_hex) {
  char hex[BUS_MONITOR_MAX_RAW * 3];
  assert_int_equal(s->p.kind, kind);
  assert_string_equal(s->sender, sender);
  assert_string_equal(packet_hex(s->raw, s->p.raw_count, hex, sizeof(hex)), raw_hex);
}

static void test_a_packet_is_reported_when_its_last_byte_is_finalized(void **state) {
  (void)state;
  rig_t *r = rig_new();
  const uint8_t ping[] = {0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
  sim_cycles_t end = 0;
  for (size_t i = 0; i < sizeof(ping); i++) {
    end = send(r, r->client, &ping[i], 1, 1000 + i * BYTE_CYCLES);
    assert_int_equal(r->log.count, i + 1 == sizeof(ping) ? 1 : 0);
  }
  const bus_packet_t *p = &r->log.r[0].p;
  assert_record(&r->log.r[0], BUS_PACKET_INSTRUCTION, "client", "FF FF 01 02 01 FB");
  assert_int_equal(p->start, 1000);
  assert_int_equal(p->end, end);
  assert_int_equal(p->id, 1);
  assert_int_equal(p->length, 2);
  assert_int_equal(p->code, 0x01);
  assert_int_equal(p->param_count, 0);
  assert_true(p->checksum_ok);
  assert_false(p->collision);
  assert_int_equal(bus_monitor_count(r->mon, BUS_PACKET_INSTRUCTION), 1);
  rig_free(r);
}

static void test_garbage_between_packets_is_reported_and_the_packets_found(void **state) {
  (void)state;
  rig_t *r = rig_new();
  const uint8_t bytes[] = {0x00, 0x12, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB, 0x34, 0xFF, 0xFF,
                           0xFF, 0x01, 0x04, 0x02, 0x2B, 0x01, 0xCC, 0xFF, 0x55};
  send(r, r->client, bytes, sizeof(bytes), 0);
  assert_int_equal(r->log.count, 4);
  assert_record(&r->log.r[0], BUS_PACKET_GARBAGE, "client", "00 12");
  assert_int_equal(r->log.r[0].p.start, 0);
  assert_int_equal(r->log.r[0].p.end, 2 * BYTE_CYCLES);
  assert_record(&r->log.r[1], BUS_PACKET_INSTRUCTION, "client", "FF FF 01 02 01 FB");
  assert_record(&r->log.r[2], BUS_PACKET_GARBAGE, "client", "34");
  /* The trailing FF 55 is garbage that waits for what comes next: here, the end. */
  bus_monitor_finish(r->mon);
  assert_int_equal(r->log.count, 5);
  assert_record(&r->log.r[3], BUS_PACKET_INSTRUCTION, "client", "FF FF FF 01 04 02 2B 01 CC");
  assert_int_equal(r->log.r[3].p.code, 0x02);
  assert_int_equal(r->log.r[3].p.param_count, 2);
  assert_true(r->log.r[3].p.checksum_ok);
  assert_record(&r->log.r[4], BUS_PACKET_GARBAGE, "client", "FF 55");
  rig_free(r);
}

static void test_a_length_below_two_is_no_packet_and_the_next_one_is_found(void **state) {
  (void)state;
  rig_t *r = rig_new();
  const uint8_t bytes[] = {0xFF, 0xFF, 0x01, 0x01, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
  send(r, r->client, bytes, sizeof(bytes), 0);
  assert_int_equal(r->log.count, 2);
  assert_record(&r->log.r[0], BUS_PACKET_GARBAGE, "client", "FF FF 01 01");
  assert_record(&r->log.r[1], BUS_PACKET_INSTRUCTION, "client", "FF FF 01 02 01 FB");
  rig_free(r);
}

static void test_a_bad_checksum_is_a_packet_with_checksum_ok_false(void **state) {
  (void)state;
  rig_t *r = rig_new();
  const uint8_t bytes[] = {0xFF, 0xFF, 0x01, 0x04, 0x02, 0x2B, 0x01, 0x00, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
  send(r, r->client, bytes, sizeof(bytes), 0);
  assert_int_equal(r->log.count, 2);
  assert_record(&r->log.r[0], BUS_PACKET_INSTRUCTION, "client", "FF FF 01 04 02 2B 01 00");
  assert_false(r->log.r[0].p.checksum_ok);
  assert_int_equal(r->log.r[0].p.checksum, 0x00);
  assert_string_equal(r->log.r[0].csv,
                      "0.0000,80.0000,client,instruction,1,0x02,READ,2B 01,0,0,,FF FF 01 04 02 2B 01 00\n");
  assert_true(r->log.r[1].p.checksum_ok);
  rig_free(r);
}

static void test_a_servo_packet_is_a_status_with_its_error_bits_named(void **state) {
  (void)state;
  rig_t *r = rig_new();
  uint8_t request[16], reply[16];
  const uint8_t read_params[] = {0x2B, 0x01};
  const size_t n_req = packet_encode(request, 1, 0x02, read_params, sizeof(read_params));
  const uint8_t temperature = 0x20;
  const size_t n_reply = packet_encode(reply, 1, 0x48, &temperature, 1);
  const sim_cycles_t end = send(r, r->client, request, n_req, 0);
  send(r, r->servo1, reply, n_reply, end + sim_us(500));
  assert_int_equal(r->log.count, 2);
  assert_record(&r->log.r[1], BUS_PACKET_STATUS, "servo-1", "FF FF 01 03 48 20 93");
  const bus_packet_t *p = &r->log.r[1].p;
  assert_int_equal(p->code, 0x48);
  assert_int_equal(p->param_count, 1);
  assert_int_equal(p->params[0], 0x20);
  assert_true(p->checksum_ok);
  assert_int_equal(p->start, end + sim_us(500));
  char line[BUS_PACKET_CSV_MAX];
  const size_t n = bus_packet_csv(p, line, sizeof(line));
  assert_int_equal(n, strlen(line));
  assert_string_equal(line, "580.0000,650.0000,servo-1,status,1,0x48,RANGE|INSTRUCTION,20,1,0,,FF FF 01 03 48 20 93\n");
  char names[BUS_PACKET_ERROR_NAMES_MAX];
  assert_string_equal(bus_packet_error_names(0, names, sizeof(names)), "NONE");
  assert_string_equal(bus_packet_error_names(0xFF, names, sizeof(names)),
                      "VOLTAGE|ANGLE_LIMIT|OVERHEATING|RANGE|CHECKSUM|OVERLOAD|INSTRUCTION|BIT7");
  assert_string_equal(bus_packet_error_names(0x09, names, 13), "VOLTAGE"); /* no name cut */
  assert_string_equal(bus_packet_instruction_name(0x83), "SYNC_WRITE");
  assert_null(bus_packet_instruction_name(0x07));
  rig_free(r);
}

static void test_a_second_master_sends_instructions_under_its_own_name(void **state) {
  (void)state;
  rig_t *r = rig_new();
  bus_monitor_add_master(r->mon, r->servo2); /* node 2 stands for the control socket's master */
  uint8_t request[16], reply[16];
  const uint8_t write_params[] = {0x19, 0x01};
  const size_t n_req = packet_encode(request, 1, 0x03, write_params, sizeof(write_params));
  const size_t n_reply = packet_encode(reply, 1, 0x00, NULL, 0);
  const sim_cycles_t end = send(r, r->servo2, request, n_req, 0);
  send(r, r->servo1, reply, n_reply, end + sim_us(500));
  assert_int_equal(r->log.count, 2);
  assert_record(&r->log.r[0], BUS_PACKET_INSTRUCTION, "servo-2", "FF FF 01 04 03 19 01 DD");
  assert_int_equal(r->log.r[0].p.code, 0x03);
  assert_record(&r->log.r[1], BUS_PACKET_STATUS, "servo-1", "FF FF 01 02 00 FC");
  rig_free(r);
}

static void test_another_sender_ends_a_partial_packet_which_is_garbage(void **state) {
  (void)state;
  rig_t *r = rig_new();
  const uint8_t cut[] = {0xFF, 0xFF, 0x01, 0x04, 0x02};
  const uint8_t status[] = {0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC};
  const sim_cycles_t end = send(r, r->client, cut, sizeof(cut), 0);
  assert_int_equal(r->log.count, 0);
  send(r, r->servo1, status, sizeof(status), end + 100);
  assert_int_equal(r->log.count, 2);
  assert_record(&r->log.r[0], BUS_PACKET_GARBAGE, "client", "FF FF 01 04 02");
  assert_record(&r->log.r[1], BUS_PACKET_STATUS, "servo-1", "FF FF 01 02 00 FC");
  assert_string_equal(r->log.r[1].csv, "56.2500,116.2500,servo-1,status,1,0x00,NONE,,1,0,,FF FF 01 02 00 FC\n");
  rig_free(r);
}

/* A broadcast PING's replies at equal Return Delay Times, servo 2 starting `lag` cycles later
 * (0: in lockstep, each byte starting as the other's previous byte ends). */
static void colliding_replies(sim_cycles_t lag) {
  rig_t *r = rig_new();
  uint8_t a[8], b[8];
  const size_t na = packet_encode(a, 1, 0x00, NULL, 0);
  const size_t nb = packet_encode(b, 2, 0x00, NULL, 0);
  sim_cycles_t end_a = 0, end_b = 0;
  for (size_t i = 0; i < na; i++) {
    end_a = bus_send(&r->bus, r->servo1, a[i], i ? end_a : 1000);
    end_b = bus_send(&r->bus, r->servo2, b[i], i ? end_b : 1000 + lag);
  }
  bus_finalize(&r->bus, end_b);
  assert_int_equal(r->log.count, 2);
  assert_int_equal(nb, na);
  assert_record(&r->log.r[0], BUS_PACKET_STATUS, "servo-1", "FF FF 01 02 00 FC");
  assert_record(&r->log.r[1], BUS_PACKET_STATUS, "servo-2", "FF FF 02 02 00 FB");
  assert_true(r->log.r[0].p.collision);
  assert_true(r->log.r[1].p.collision);
  assert_true(r->log.r[0].p.checksum_ok); /* as sent: each receiver decodes the wired-AND */
  assert_non_null(strstr(r->log.r[1].csv, ",1,1,,FF FF 02"));
  rig_free(r);
}

static void test_colliding_replies_are_both_reported_with_the_collision_flag(void **state) {
  (void)state;
  colliding_replies(4);
  colliding_replies(0);
}

static void test_a_protocol_2_frame_is_skipped_whole_and_keeps_sync(void **state) {
  (void)state;
  rig_t *r = rig_new();
  /* A 2.0 WRITE whose data holds a whole 1.0 PING, then a 1.0 PING. */
  const uint8_t bytes[] = {0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x0B, 0x00, 0x03, 0x74, 0x00, 0xFF, 0xFF,
                           0x01, 0x02, 0x01, 0xFB, 0x12, 0x34, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
  send(r, r->client, bytes, sizeof(bytes), 0);
  assert_int_equal(r->log.count, 2);
  assert_record(&r->log.r[0], BUS_PACKET_PROTOCOL2, "client",
                "FF FF FD 00 01 0B 00 03 74 00 FF FF 01 02 01 FB 12 34");
  assert_string_equal(r->log.r[0].csv,
                      "0.0000,180.0000,client,protocol2,,,,,,0,,"
                      "FF FF FD 00 01 0B 00 03 74 00 FF FF 01 02 01 FB 12 34\n");
  assert_record(&r->log.r[1], BUS_PACKET_INSTRUCTION, "client", "FF FF 01 02 01 FB");
  assert_int_equal(bus_monitor_count(r->mon, BUS_PACKET_INSTRUCTION), 1);
  rig_free(r);
}

static void test_a_long_protocol_2_frame_comes_in_several_records(void **state) {
  (void)state;
  rig_t *r = rig_new();
  const size_t body = 600; /* LEN: more than one record holds */
  uint8_t header[] = {0xFF, 0xFF, 0xFD, 0x00, 0xFE, (uint8_t)(body & 0xFF), (uint8_t)(body >> 8)};
  sim_cycles_t t = 0;
  for (size_t i = 0; i < sizeof(header); i++, t += BYTE_CYCLES) {
    feed(r, r->client, header[i], t);
  }
  const uint8_t ping[] = {0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
  for (size_t i = 0; i < body; i++, t += BYTE_CYCLES) {
    feed(r, r->client, ping[i % sizeof(ping)], t);
  }
  for (size_t i = 0; i < sizeof(ping); i++, t += BYTE_CYCLES) {
    feed(r, r->client, ping[i], t);
  }
  assert_int_equal(r->log.count, 3);
  assert_int_equal(r->log.r[0].p.kind, BUS_PACKET_PROTOCOL2);
  assert_int_equal(r->log.r[1].p.kind, BUS_PACKET_PROTOCOL2);
  assert_int_equal(r->log.r[0].p.raw_count + r->log.r[1].p.raw_count, sizeof(header) + body);
  assert_record(&r->log.r[2], BUS_PACKET_INSTRUCTION, "client", "FF FF 01 02 01 FB");
  rig_free(r);
}

static void test_a_gap_ends_a_partial_packet(void **state) {
  (void)state;
  rig_t *r = rig_new();
  const uint8_t ping[] = {0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
  feed(r, r->client, 0xFF, 0);
  feed(r, r->client, 0xFF, BYTE_CYCLES);
  feed(r, r->client, 0x01, 2 * BYTE_CYCLES);
  /* Within the gap the packet goes on. */
  sim_cycles_t t = 3 * BYTE_CYCLES + GAP_CYCLES;
  bus_monitor_flush(r->mon, t);
  assert_int_equal(r->log.count, 0);
  feed(r, r->client, 0x02, t);
  feed(r, r->client, 0x01, t + BYTE_CYCLES);
  feed(r, r->client, 0xFB, t + 2 * BYTE_CYCLES);
  assert_int_equal(r->log.count, 1);
  assert_record(&r->log.r[0], BUS_PACKET_INSTRUCTION, "client", "FF FF 01 02 01 FB");
  /* Past the gap it is garbage, and the packet after it is found. */
  t += 3 * BYTE_CYCLES;
  feed(r, r->client, 0xFF, t);
  feed(r, r->client, 0xFF, t + BYTE_CYCLES);
  t += 2 * BYTE_CYCLES + GAP_CYCLES + 1;
  for (size_t i = 0; i < sizeof(ping); i++) {
    feed(r, r->client, ping[i], t + i * BYTE_CYCLES);
  }
  assert_int_equal(r->log.count, 3);
  assert_record(&r->log.r[1], BUS_PACKET_GARBAGE, "client", "FF FF");
  assert_record(&r->log.r[2], BUS_PACKET_INSTRUCTION, "client", "FF FF 01 02 01 FB");
  /* A cut packet at the end is reported by a flush past the gap. */
  t += sizeof(ping) * BYTE_CYCLES;
  feed(r, r->servo1, 0xFF, t);
  bus_monitor_flush(r->mon, t + BYTE_CYCLES + GAP_CYCLES);
  assert_int_equal(r->log.count, 3);
  bus_monitor_flush(r->mon, t + BYTE_CYCLES + GAP_CYCLES + 1);
  assert_int_equal(r->log.count, 4);
  assert_record(&r->log.r[3], BUS_PACKET_GARBAGE, "servo-1", "FF");
  rig_free(r);
}

static void test_noise_and_truncation_are_flagged(void **state) {
  (void)state;
  rig_t *r = rig_new();
  const uint8_t ping[] = {0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
  for (size_t i = 0; i < sizeof(ping); i++) {
    const bus_tap_byte_t b = {.start = i * BYTE_CYCLES,
                              .end = (i + 1) * BYTE_CYCLES,
                              .sent = ping[i],
                              .wire = i == 4 ? 0x03 : ping[i],
                              .flags = i == 5 ? BUS_RX_TRUNCATED : 0,
                              .sender = (uint8_t)r->client};
    bus_monitor_byte(r->mon, &b);
  }
  assert_int_equal(r->log.count, 1);
  assert_true(r->log.r[0].p.noise_changed);
  assert_true(r->log.r[0].p.checksum_ok); /* decoded as sent */
  assert_string_equal(r->log.r[0].csv,
                      "0.0000,60.0000,client,instruction,1,0x01,PING,,1,0,truncated|noise,FF FF 01 02 01 FB\n");
  rig_free(r);
}

static void count_calls(void *ctx, const bus_packet_t *p) {
  (void)p;
  (*(int *)ctx)++;
}

static void test_several_listeners_get_every_record(void **state) {
  (void)state;
  rig_t *r = rig_new();
  int calls_a = 0, calls_b = 0;
  const int a = bus_monitor_add_listener(r->mon, count_calls, &calls_a);
  const int b = bus_monitor_add_listener(r->mon, count_calls, &calls_b);
  assert_true(a > 0 && b > 0 && a != b);
  const uint8_t ping[] = {0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
  const sim_cycles_t end = send(r, r->client, ping, sizeof(ping), 0);
  bus_monitor_remove_listener(r->mon, a);
  send(r, r->client, ping, sizeof(ping), end);
  assert_int_equal(r->log.count, 2);
  assert_int_equal(calls_a, 1);
  assert_int_equal(calls_b, 2);
  for (int i = 0; i < (int)BUS_MONITOR_MAX_LISTENERS - 2; i++) {
    assert_true(bus_monitor_add_listener(r->mon, count_calls, &calls_a) >= 0);
  }
  assert_int_equal(bus_monitor_add_listener(r->mon, count_calls, &calls_a), -1);
  rig_free(r);
}

static void test_a_run_of_header_bytes_never_overflows(void **state) {
  (void)state;
  rig_t *r = rig_new();
  sim_cycles_t t = 0;
  for (size_t i = 0; i < 1000; i++, t += BYTE_CYCLES) {
    feed(r, r->client, 0xFF, t);
  }
  const uint8_t ping[] = {0x01, 0x02, 0x01, 0xFB};
  for (size_t i = 0; i < sizeof(ping); i++, t += BYTE_CYCLES) {
    feed(r, r->client, ping[i], t);
  }
  bus_monitor_finish(r->mon);
  size_t garbage = 0;
  for (size_t i = 0; i + 1 < r->log.count; i++) {
    assert_int_equal(r->log.r[i].p.kind, BUS_PACKET_GARBAGE);
    garbage += r->log.r[i].p.raw_count;
  }
  const seen_t *last = &r->log.r[r->log.count - 1];
  assert_int_equal(last->p.kind, BUS_PACKET_INSTRUCTION);
  assert_int_equal(garbage + last->p.raw_count, 1000 + sizeof(ping));
  assert_true(last->p.checksum_ok);
  rig_free(r);
}

static void test_the_csv_header_names_every_column(void **state) {
  (void)state;
  assert_string_equal(BUS_PACKET_CSV_HEADER,
                      "time_us,end_us,sender,kind,id,code,code_name,params,checksum_ok,collision,line,raw\n");
  /* The longest line fits. */
  static uint8_t raw[BUS_MONITOR_MAX_RAW];
  memset(raw, 0xAB, sizeof(raw));
  const bus_packet_t p = {.kind = BUS_PACKET_STATUS,
                          .start = SIM_CYCLES_NEVER / 2,
                          .end = SIM_CYCLES_NEVER / 2,
                          .sender_name = "a-node-name-of-23-chars",
                          .code = 0xFF,
                          .params = raw,
                          .param_count = 253,
                          .line_flags = BUS_RX_TRUNCATED,
                          .noise_changed = true,
                          .raw = raw,
                          .raw_count = sizeof(raw)};
  char line[BUS_PACKET_CSV_MAX];
  const size_t n = bus_packet_csv(&p, line, sizeof(line));
  assert_true(n < sizeof(line) - 1);
  assert_int_equal(line[n - 1], '\n');
  /* A short buffer cuts the line, terminated. */
  char small[16];
  const size_t cut = bus_packet_csv(&p, small, sizeof(small));
  assert_int_equal(cut, strlen(small));
  assert_int_equal(cut, sizeof(small) - 1);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_a_packet_is_reported_when_its_last_byte_is_finalized),
      cmocka_unit_test(test_garbage_between_packets_is_reported_and_the_packets_found),
      cmocka_unit_test(test_a_length_below_two_is_no_packet_and_the_next_one_is_found),
      cmocka_unit_test(test_a_bad_checksum_is_a_packet_with_checksum_ok_false),
      cmocka_unit_test(test_a_servo_packet_is_a_status_with_its_error_bits_named),
      cmocka_unit_test(test_a_second_master_sends_instructions_under_its_own_name),
      cmocka_unit_test(test_another_sender_ends_a_partial_packet_which_is_garbage),
      cmocka_unit_test(test_colliding_replies_are_both_reported_with_the_collision_flag),
      cmocka_unit_test(test_a_protocol_2_frame_is_skipped_whole_and_keeps_sync),
      cmocka_unit_test(test_a_long_protocol_2_frame_comes_in_several_records),
      cmocka_unit_test(test_a_gap_ends_a_partial_packet),
      cmocka_unit_test(test_noise_and_truncation_are_flagged),
      cmocka_unit_test(test_several_listeners_get_every_record),
      cmocka_unit_test(test_a_run_of_header_bytes_never_overflows),
      cmocka_unit_test(test_the_csv_header_names_every_column),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
