/* SPDX-License-Identifier: GPL-3.0-or-later */
/* One framing rule for every reader (docs/policy.md "Framing and bus"): the same random stream
 * goes to the ELF in simavr (its RX interrupt frames every byte, its link layer takes the
 * packets) and to the host bus of the core tests (test/core/host_bus.h: the same link layer on
 * a fake UART whose receiver frames with the core's step, the reader docs/conformance.md is
 * generated from). The stream mixes packets for this servo, for others and broadcast, other
 * servos' status packets, garbage, packets with a byte changed (this servo's and others'),
 * packets cut short and then a gap, extra 0xFF, and Protocol 2.0 frames (some with a whole 1.0
 * packet inside). What the master hears must be the same bytes on both, byte for byte, every
 * time: the test fails on the first difference.
 *
 * The master behaves as a real one: it stops sending while a reply is due. The stream goes to
 * the host bus a byte at a time; when a byte makes the host bus answer, the ELF gets the bytes
 * up to it and the master waits for as many bytes from it (the host answers before the next
 * byte; the ELF after its Return Delay Time, 0 here, or, for a reply its main loop composes,
 * about 100 us later), then a short quiet time, and goes on. A reply the host does not give,
 * or a byte that differs, shows in what the master hears next.
 *
 * Only items both sides hold alike are read (the host bus has no plant: no Present Position,
 * Speed or Load), writes stay in the RAM items up to Torque Limit (no ID, baud, Return Delay
 * Time or Lock change), and after every gap both are set to the same RAM items.
 *
 * AX12_DIFFERENTIAL_PIECES (environment) sets the number of pieces of the four streams
 * together; the default, 1 000 000, is the CI's (two ctest entries of two streams each). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <sim_avr.h>

#include "dxl_protocol.h"
#include "dxl_table.h"
#include "elf_symbols.h"
#include "host_bus.h"
#include "sim_harness.h"
#include "xorshift32.h"

#define OWN_ID 1u
#define DEFAULT_PIECES 1000000u
#define SEEDS 4u
#define GAP_MS 110u                     /* more than the 100 ms that ends a partial packet */
#define REPLY_WAIT_US 3000u             /* the longest a reply may take to come whole */
#define QUIET_US 20u                    /* after a reply: the ELF's receiver is back on */
#define NO_REPLY_PAUSE_US 40u           /* after a packet the servo keeps without a reply */

typedef struct {
  uint32_t state;
} rng_t;

static uint32_t next(rng_t *r) { return xorshift32_next(&r->state); }

static uint8_t pick(rng_t *r, const uint8_t *from, size_t count) { return from[next(r) % count]; }

/* Addresses whose values the ELF and the host bus share (no plant, no control tick on the
 * host): the EEPROM area but the calibration, and the RAM items a client sets. */
static const uint8_t readable[] = {0, 2, 3, 4, 5, 6, 11, 12, 13, 14, 16, 17, 18, 24, 25, 26, 27, 28, 29, 32, 34, 44, 47};

/* A packet of some kind into out; returns its length. */
static size_t random_packet(rng_t *r, uint8_t *out, uint8_t id) {
  uint8_t params[8];
  switch (next(r) % 5u) {
  case 0:
    return packet_encode(out, id, DXL_INST_PING, NULL, 0);
  case 1:
    params[0] = pick(r, readable, sizeof readable);
    params[1] = (uint8_t)(1u + next(r) % 2u);
    return packet_encode(out, id, DXL_INST_READ, params, 2);
  case 2:
    params[0] = CT_ADDR_LED;
    params[1] = (uint8_t)(next(r) % 2u);
    return packet_encode(out, id, DXL_INST_WRITE, params, 2);
  case 3:
    params[0] = CT_ADDR_CW_COMPLIANCE_MARGIN;
    params[1] = (uint8_t)(next(r) % 8u);
    params[2] = (uint8_t)(next(r) % 8u);
    return packet_encode(out, id, DXL_INST_WRITE, params, 3);
  default: { /* any instruction but RESET, parameters that need not fit it; a write starts
              * past the EEPROM area (ID, baud and Return Delay Time stay as they are) */
    static const uint8_t instructions[] = {0, DXL_INST_PING, DXL_INST_READ, DXL_INST_WRITE, DXL_INST_REG_WRITE,
                                           DXL_INST_ACTION, 7, DXL_INST_SYNC_WRITE};
    const size_t count = next(r) % 6u;
    for (size_t i = 0; i < count; i++) {
      params[i] = (uint8_t)next(r);
    }
    /* the RAM items up to Torque Limit, or past the table (a Range Error): never Lock */
    params[0] = params[0] % 2u ? (uint8_t)(CT_ADDR_TORQUE_ENABLE + params[0] % 12u) : (uint8_t)(CT_SIZE + params[0] % 200u);
    const uint8_t instruction = pick(r, instructions, sizeof instructions);
    if (instruction == DXL_INST_READ && count >= 2u && params[0] < CT_ADDR_PRESENT_POSITION) {
      params[1] = (uint8_t)(1u + params[1] % (CT_ADDR_PRESENT_POSITION - params[0])); /* not the plant's items */
    }
    return packet_encode(out, id, instruction, params, count);
  }
  }
}

typedef struct {
  uint8_t bytes[64];
  size_t length;
  bool gap_after;
  const char *kind;
} piece_t;

static const uint8_t others[] = {0, 2, 3, 100, 253};

static void random_piece(rng_t *r, piece_t *s) {
  s->gap_after = false;
  const uint32_t kind = next(r) % 1000u;
  if (kind < 200) {
    s->kind = "this servo's packet";
    s->length = random_packet(r, s->bytes, OWN_ID);
  } else if (kind < 330) {
    s->kind = "another servo's packet";
    s->length = random_packet(r, s->bytes, pick(r, others, sizeof others));
  } else if (kind < 430) {
    s->kind = "a broadcast WRITE of the LED";
    const uint8_t params[] = {CT_ADDR_LED, (uint8_t)(next(r) % 2u)};
    s->length = packet_encode(s->bytes, DXL_ID_BROADCAST, DXL_INST_WRITE, params, sizeof params);
  } else if (kind < 530) {
    s->kind = "another servo's status packet";
    const uint8_t params[] = {(uint8_t)next(r)};
    s->length = packet_encode(s->bytes, pick(r, others, sizeof others), 0, params, next(r) % 2u);
  } else if (kind < 630) {
    s->kind = "garbage";
    s->length = 1u + next(r) % 12u;
    for (size_t i = 0; i < s->length; i++) {
      s->bytes[i] = next(r) % 3u == 0 ? DXL_HEADER_BYTE : (uint8_t)next(r);
    }
  } else if (kind < 730) {
    s->kind = "this servo's packet with one byte changed";
    s->length = random_packet(r, s->bytes, OWN_ID);
    s->bytes[next(r) % s->length] = (uint8_t)next(r);
  } else if (kind < 830) {
    s->kind = "another servo's packet with one byte changed";
    s->length = random_packet(r, s->bytes, pick(r, others, sizeof others));
    s->bytes[next(r) % s->length] = (uint8_t)next(r);
  } else if (kind < 880) {
    s->kind = "a Protocol 2.0 frame";
    /* FF FF FD 00 ID LEN_L LEN_H, LEN bytes: instruction, data (at times a whole 1.0 packet of
     * this servo), a CRC the 1.0 readers do not check */
    uint8_t *b = s->bytes;
    size_t n = 0;
    b[n++] = DXL_HEADER_BYTE;
    b[n++] = DXL_HEADER_BYTE;
    b[n++] = 0xFD;
    b[n++] = 0x00;
    b[n++] = next(r) % 2u ? OWN_ID : pick(r, others, sizeof others);
    const size_t len_at = n;
    n += 2u;
    b[n++] = (uint8_t)(1u + next(r) % 3u); /* PING, READ, WRITE */
    if (next(r) % 2u) {
      n += packet_encode(&b[n], OWN_ID, DXL_INST_PING, NULL, 0);
    } else {
      for (size_t i = next(r) % 8u; i > 0; i--) {
        b[n++] = next(r) % 3u == 0 ? DXL_HEADER_BYTE : (uint8_t)next(r);
      }
    }
    b[n++] = (uint8_t)next(r);
    b[n++] = (uint8_t)next(r);
    const size_t len = n - len_at - 2u;
    b[len_at] = (uint8_t)len;
    b[len_at + 1u] = 0;
    s->length = n;
  } else if (kind < 940) {
    s->kind = "extra 0xFF, then this servo's packet";
    s->bytes[0] = DXL_HEADER_BYTE;
    s->length = 1u + random_packet(r, &s->bytes[1], OWN_ID);
  } else if (kind < 942) {
    s->kind = "a packet cut short, then a gap";
    s->length = random_packet(r, s->bytes, next(r) % 2u ? OWN_ID : pick(r, others, sizeof others));
    s->length = 1u + next(r) % (s->length - 1u);
    s->gap_after = true;
  } else {
    s->kind = "this servo's PING";
    s->length = packet_encode(s->bytes, OWN_ID, DXL_INST_PING, NULL, 0);
  }
}

static void hex(const uint8_t *bytes, size_t count, char *out, size_t out_len) { packet_hex(bytes, count, out, out_len); }

typedef struct {
  harness_t h;
  host_bus_t *host;
  piece_t history[8];
  unsigned piece;
  unsigned answered; /* pieces the host answered */
  unsigned replies;  /* replies compared */
} run_t;

static void fail_difference(run_t *run, const char *what, const uint8_t *sent, size_t sent_len, const uint8_t *host_heard,
                            size_t host_len, const uint8_t *elf_heard, size_t elf_len) {
  char text[3][800];
  hex(sent, sent_len, text[0], sizeof text[0]);
  hex(host_heard, host_len, text[1], sizeof text[1]);
  hex(elf_heard, elf_len, text[2], sizeof text[2]);
  print_message("piece %u (%s): %s\n  sent %s\n  host reader heard %s\n  ELF heard         %s\n", run->piece,
                run->history[7].kind, what, text[0], text[1], text[2]);
  for (size_t k = 0; k < 8; k++) {
    hex(run->history[k].bytes, run->history[k].length, text[0], sizeof text[0]);
    print_message("  before it (%s): %s%s\n", run->history[k].kind, text[0], run->history[k].gap_after ? ", gap" : "");
  }
  /* The receiver's and the reply's state in the ELF, for the reader of the failure. */
  static const char *const symbols[] = {"uart_tx_state",  "uart_tx_published", "uart_tx_length", "uart_rx_armed",
                                        "uart_rx_head",   "uart_rx_tail",      "uart_rx_mode",   "uart_listening",
                                        "uart_rx_frame"};
  for (size_t i = 0; i < sizeof symbols / sizeof symbols[0]; i++) {
    uint32_t address;
    if (elf_symbol_address(run->h.elf, symbols[i], &address)) {
      print_message("  ELF %s = %u\n", symbols[i], run->h.world->servos[0]->avr->data[address]);
    }
  }
  fail_msg("the ELF and the host reader answered piece %u differently", run->piece);
}

/* The bytes the master heard from the ELF since its last clear, up to max. */
static size_t elf_heard(const run_t *run, uint8_t *out, size_t max) {
  size_t n = 0;
  for (size_t k = 0; k < master_rx_count(run->h.master) && n < max; k++) {
    out[n++] = master_rx(run->h.master, k)->value;
  }
  return n;
}

/* Sends bytes to both; after each byte that makes the host answer, the master waits for the
 * ELF's answer and compares. */
static void send_both(run_t *run, const uint8_t *bytes, size_t length) {
  harness_t *h = &run->h;
  host_bus_t *host = run->host;
  size_t from = 0;
  while (from < length) {
    host->heard_len = 0;
    size_t to = from;
    while (to < length && host->heard_len == 0) {
      host_bus_send_more(host, &bytes[to++], 1);
    }
    master_rx_clear(h->master);
    const sim_cycles_t end = master_send(h->master, &bytes[from], to - from);
    world_run_until(h->world, end);
    const size_t expect = host->heard_len;
    if (expect != 0) {
      const sim_cycles_t limit = end + sim_us(REPLY_WAIT_US);
      while (master_rx_count(h->master) < expect && h->world->now < limit) {
        world_run_until(h->world, h->world->now + sim_us(5));
      }
      world_run_until(h->world, h->world->now + sim_us(QUIET_US));
      run->answered++;
    }
    uint8_t heard[HARNESS_MAX_REPLY];
    const size_t got = elf_heard(run, heard, sizeof heard);
    if (got != expect || memcmp(heard, host->heard, got) != 0) {
      fail_difference(run, "heard differently", bytes, length, host->heard, expect, heard, got);
    }
    run->replies += expect != 0;
    from = to;
  }
}

/* The line idles: on the ELF for us microseconds, and no byte may come meanwhile. */
static void idle_both(run_t *run, unsigned us) {
  master_rx_clear(run->h.master);
  world_run_until(run->h.world, run->h.world->now + sim_us(us));
  host_bus_wait_ms(run->host, (us + 999u) / 1000u);
  uint8_t heard[HARNESS_MAX_REPLY];
  const size_t got = elf_heard(run, heard, sizeof heard);
  if (got != 0) {
    fail_difference(run, "the ELF spoke while the line idled", NULL, 0, NULL, 0, heard, got);
  }
}

/* A byte of the firmware's RAM by symbol (the ELF has it: the test fails otherwise). */
static unsigned firmware_byte(const harness_t *h, const char *symbol) {
  uint32_t address;
  if (!elf_symbol_address(h->elf, symbol, &address)) {
    fail_msg("the firmware ELF %s has no symbol %s", h->elf, symbol);
  }
  return h->world->servos[0]->avr->data[address];
}

/* One stream from seed: pieces pieces. */
static void run_stream(uint32_t seed, unsigned pieces) {
  static host_bus_t host;
  static run_t run;
  memset(&run, 0, sizeof run);
  run.host = &host;
  const uint8_t ids[] = {OWN_ID};
  host_bus_init(&host, ids, 1, 1, 25);
  harness_open(&run.h, "ax12", "atmega88", 1);
  harness_add_servo(&run.h, OWN_ID, 1, NULL);
  harness_boot(&run.h, 5);

  /* Return Delay Time 0 on both: a reply comes at once, or late from the main loop. */
  uint8_t setup[16];
  const uint8_t rdt0[] = {CT_ADDR_RETURN_DELAY_TIME, 0};
  send_both(&run, setup, packet_encode(setup, OWN_ID, DXL_INST_WRITE, rdt0, sizeof rdt0));

  rng_t r = {seed};
  unsigned gaps = 0;
  for (run.piece = 0; run.piece < pieces; run.piece++) {
    piece_t *s = &run.history[7];
    memmove(&run.history[0], &run.history[1], sizeof run.history - sizeof run.history[0]);
    random_piece(&r, s);
    send_both(&run, s->bytes, s->length);
    if (s->gap_after) {
      idle_both(&run, GAP_MS * 1000u);
      gaps++;
      /* Both start again from the same RAM items and no registered write (the control tick
       * of the ELF moves what the host bus has not got: Present items, Moving). */
      static const uint8_t same_ram[] = {CT_ADDR_TORQUE_ENABLE, 0, 0, 0, 0, 32, 32, 0x00, 0x02, 0, 0, 0xFF, 0x03};
      static const uint8_t nothing_registered[] = {CT_ADDR_REGISTERED_INSTRUCTION, 0};
      uint8_t restore[32];
      send_both(&run, restore, packet_encode(restore, OWN_ID, DXL_INST_WRITE, same_ram, sizeof same_ram));
      send_both(&run, restore,
                packet_encode(restore, OWN_ID, DXL_INST_WRITE, nothing_registered, sizeof nothing_registered));
    } else if (host.heard_len == 0) {
      /* A packet the servo keeps without a reply takes its main loop a while: the master, as
       * a real one, does not send the next at once (back-to-back short packets are more than
       * the firmware can take: docs/firmware.md "Load"). */
      world_run_until(run.h.world, run.h.world->now + sim_us(NO_REPLY_PAUSE_US));
    }
  }
  idle_both(&run, 5000u); /* nothing late either */
  const unsigned dropped = firmware_byte(&run.h, "uart_rx_dropped_count");
  print_message("seed 0x%04X: %u pieces of stream, %u gaps: %u replies heard alike from the ELF and the host reader, "
                "%u bytes the ELF dropped\n",
                (unsigned)seed, pieces, gaps, run.replies, dropped);
  harness_close(&run.h);
  assert_int_equal(dropped, 0);
  assert_true(run.replies > pieces / 10u);
}

/* The streams this run takes: argv selects some of the seeds by index (ctest runs them in
 * two halves side by side), all of them without arguments. */
static const uint32_t seeds[SEEDS] = {0x5EED, 0xBEEF, 0xCAFE, 0x1357};
static bool seed_chosen[SEEDS];

static void test_the_elf_and_the_host_reader_answer_every_stream_alike(void **state) {
  (void)state;
  const char *env = getenv("AX12_DIFFERENTIAL_PIECES");
  const unsigned pieces = env != NULL ? (unsigned)strtoul(env, NULL, 10) : DEFAULT_PIECES;
  for (size_t i = 0; i < SEEDS; i++) {
    if (seed_chosen[i]) {
      run_stream(seeds[i], (pieces + SEEDS - 1u) / SEEDS);
    }
  }
}

int main(int argc, char **argv) {
  for (size_t i = 0; i < SEEDS; i++) {
    seed_chosen[i] = argc < 2;
  }
  for (int a = 1; a < argc; a++) {
    const unsigned long index = strtoul(argv[a], NULL, 10);
    if (index >= SEEDS) {
      fprintf(stderr, "usage: %s [seed index 0..%u]...\n", argv[0], SEEDS - 1u);
      return 2;
    }
    seed_chosen[index] = true;
  }
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_the_elf_and_the_host_reader_answer_every_stream_alike),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
