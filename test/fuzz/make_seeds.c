/* Writes the seed corpus of fuzz_core (test/fuzz/corpus/): one file per scenario, each a
 * script in the format of fuzz_ops.h, covering every instruction, addressing and error path,
 * the armed path, gaps, control alarms, EEPROM stores cut at a byte, and the starting
 * states. Usage: fuzz_make_seeds <directory>. The committed corpus is its output; run it again
 * after changing the format or a scenario. */
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dxl_protocol.h"
#include "fuzz_ops.h"

static uint8_t buf[4096];
static size_t len;
static const char *dir;

static void b(unsigned v) { buf[len++] = (uint8_t)v; }
static void b16(unsigned v) {
  b(v & 0xFFu);
  b(v >> 8);
}
static void bytes(int n, ...) {
  va_list args;
  va_start(args, n);
  for (int i = 0; i < n; i++) {
    b((unsigned)va_arg(args, int));
  }
  va_end(args);
}

static void save(const char *name) {
  char path[512];
  snprintf(path, sizeof path, "%s/%s", dir, name);
  FILE *f = fopen(path, "wb");
  if (f == NULL || fwrite(buf, 1, len, f) != len || fclose(f) != 0) {
    perror(path);
    exit(1);
  }
  len = 0;
}

/* area: ID, baud, RDT, SRL, CW, CCW, Max Torque, Alarm LED, Alarm Shutdown */
static void area(unsigned id, unsigned baud, unsigned rdt, unsigned srl, unsigned cw, unsigned ccw, unsigned torque,
                 unsigned led, unsigned shutdown) {
  bytes(4, id, baud, rdt, srl);
  b16(cw);
  b16(ccw);
  b16(torque);
  bytes(2, led, shutdown);
}
static void factory_area(unsigned id) { area(id, 1, 250, 2, 0, 1023, 1023, 4, 4); }

static void start_blank(void) {
  b(FUZZ_START_BLANK);
  b16(512);
}
static void start_one(unsigned id) {
  b(FUZZ_START_ONE_SLOT);
  factory_area(id);
  b16(512);
}

/* Packets in the instruction's own shape. */
static void ping(unsigned id_sel, unsigned mode) { bytes(3, FUZZ_OP_PACKET, FUZZ_SEL(id_sel, FUZZ_INST_PING), mode); }
static void read_(unsigned id_sel, unsigned mode, unsigned addr, unsigned n) {
  bytes(5, FUZZ_OP_PACKET, FUZZ_SEL(id_sel, FUZZ_INST_READ), mode, addr, n);
}
static void write1(unsigned inst, unsigned id_sel, unsigned mode, unsigned addr, unsigned value) {
  bytes(6, FUZZ_OP_PACKET, FUZZ_SEL(id_sel, inst), mode, addr, 0, value);
}
static void write2(unsigned inst, unsigned id_sel, unsigned mode, unsigned addr, unsigned value) {
  bytes(7, FUZZ_OP_PACKET, FUZZ_SEL(id_sel, inst), mode, addr, 1, value & 0xFFu, value >> 8);
}
static void bare(unsigned inst, unsigned id_sel, unsigned mode) { bytes(3, FUZZ_OP_PACKET, FUZZ_SEL(id_sel, inst), mode); }
static void ticks(unsigned n, unsigned many, unsigned pos, int step, unsigned volts, unsigned temp) {
  bytes(3, FUZZ_OP_TICKS, n, many);
  b16(pos);
  bytes(3, (uint8_t)(int8_t)step, volts, temp);
}
static void eeprom(unsigned writes) { bytes(2, FUZZ_OP_EEPROM, writes - 1u); }
static void flush(void) { b(FUZZ_OP_EEPROM_FLUSH); }
static void cut(unsigned torn, unsigned garbage) {
  bytes(3, FUZZ_OP_CUT, torn, garbage);
  b16(500);
}
static void wait(unsigned ms) { bytes(2, FUZZ_OP_WAIT, ms); }

int main(int argc, char **argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: %s <corpus directory>\n", argv[0]);
    return 2;
  }
  dir = argv[1];
  const unsigned W = FUZZ_INST_WRITE, R = FUZZ_INST_REG_WRITE;
  const unsigned OWN = FUZZ_ID_OWN, BC = FUZZ_ID_BROADCAST;
  const unsigned BYTES = FUZZ_DELIVER_BYTES, BATCH = FUZZ_DELIVER_BATCH, EARLY = FUZZ_DELIVER_EARLY;

  start_blank();
  ping(OWN, BATCH);
  ping(OWN, EARLY);
  ping(BC, BYTES);
  save("ping_blank");

  start_one(1);
  read_(OWN, EARLY, 0, 50);
  read_(OWN, BATCH, 49, 2);
  read_(OWN, BATCH, 0, 0);
  read_(FUZZ_ID_NEIGHBOUR, BATCH, 0, 50);
  save("read_ranges");

  start_one(1);
  write1(W, OWN, BYTES, 25, 1);
  write1(W, OWN, EARLY, 25, 0);
  write2(W, OWN, EARLY, 30, 700);
  write2(W, OWN, EARLY, 30, 1024);
  save("write_ram");

  start_one(1);
  write1(W, OWN, BATCH, 3, 7);
  ping(OWN, EARLY);
  eeprom(3);
  cut(1, 0x55);
  ping(OWN, BATCH);
  save("write_id_cut");

  start_one(1);
  write1(W, OWN, EARLY, 4, 3);
  write1(W, OWN, EARLY, 5, 0);
  flush();
  cut(0, 0);
  save("write_baud_rdt");

  start_one(1);
  write2(R, OWN, EARLY, 30, 300);
  bare(FUZZ_INST_ACTION, OWN, EARLY);
  bare(FUZZ_INST_ACTION, OWN, BATCH);
  write1(R, OWN, BATCH, 4, 3);
  bare(FUZZ_INST_ACTION, OWN, EARLY);
  save("reg_write_action");

  start_one(9);
  write1(W, OWN, BATCH, 11, 100);
  flush();
  bare(FUZZ_INST_RESET, OWN, BATCH);
  eeprom(4);
  cut(1, 0xA5);
  save("reset_cut");

  start_one(1);
  /* SYNC_WRITE LED, L = 1, 3 slices: another ID, this servo, this servo again */
  bytes(8, FUZZ_OP_PACKET, FUZZ_SEL(BC, FUZZ_INST_SYNC_WRITE), BATCH, 25, 0, 3, 0, 2);
  bytes(4, 1, 1, 1, 0);
  /* SYNC_WRITE of two bytes of the EEPROM area */
  bytes(7, FUZZ_OP_PACKET, FUZZ_SEL(BC, FUZZ_INST_SYNC_WRITE), BATCH, 5, 1, 1, 1);
  bytes(2, 10, 0);
  save("sync_write");

  start_one(1);
  /* SYNC_WRITE with L = 255 (raw): ignored whole */
  bytes(6, FUZZ_OP_PACKET, FUZZ_SEL(BC, FUZZ_INST_SYNC_WRITE) | FUZZ_SEL_RAW_PARAMS, BATCH, 4, 25, 255);
  bytes(2, 1, 1);
  /* SYNC_WRITE to this servo's own ID: Instruction Error */
  bytes(8, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_SYNC_WRITE), BATCH, 25, 0, 1, 1, 1);
  save("sync_write_odd");

  start_one(1);
  write1(W, OWN, BATCH, 47, 1);
  write1(W, OWN, BATCH, 3, 5);
  write1(W, OWN, EARLY, 25, 1);
  write2(W, OWN, EARLY, 48, 40);
  bare(FUZZ_INST_RESET, OWN, BATCH);
  write1(W, OWN, BATCH, 47, 0);
  cut(0, 0);
  write1(W, OWN, BATCH, 3, 5);
  save("lock");

  start_one(1);
  write2(R, OWN, BATCH, 48, 50);
  write1(W, OWN, BATCH, 47, 1);
  bare(FUZZ_INST_ACTION, OWN, EARLY);
  save("lock_registered");

  start_one(1);
  bytes(9, FUZZ_OP_PACKET, FUZZ_SEL(OWN, W), BATCH, 6, 3, 0, 0, 0, 0); /* wheel mode */
  write2(W, OWN, EARLY, 32, 1500);
  write2(W, OWN, EARLY, 30, 100);
  ticks(20, 0, 500, 0, 96, 25);
  write2(W, OWN, BATCH, 8, 1023); /* back to joint mode */
  ticks(5, 0, 500, 0, 96, 25);
  save("wheel_mode");

  start_one(1);
  write1(W, OWN, BATCH, 16, 0);
  read_(OWN, BATCH, 0, 2);
  ping(OWN, EARLY);
  write1(W, OWN, BATCH, 16, 1);
  read_(OWN, EARLY, 36, 2);
  write1(W, OWN, EARLY, 25, 1);
  save("status_return_levels");

  start_one(1);
  bytes(4, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_PING), BATCH | FUZZ_MODE_BAD_CHECKSUM, 1);
  bytes(4, FUZZ_OP_PACKET, FUZZ_SEL(BC, FUZZ_INST_PING), BATCH | FUZZ_MODE_BAD_CHECKSUM, 1);
  bytes(5, FUZZ_OP_PACKET, FUZZ_SEL(FUZZ_ID_GIVEN, FUZZ_INST_PING), BATCH | FUZZ_MODE_BAD_CHECKSUM, 7, 1);
  bytes(7, FUZZ_OP_PACKET, FUZZ_SEL(OWN, W), EARLY | FUZZ_MODE_BAD_CHECKSUM, 25, 0, 1, 0x80);
  save("bad_checksums");

  start_one(1);
  /* a packet split by 101 ms, and one by exactly 100 ms */
  bytes(7, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_READ), FUZZ_DELIVER_SPLIT, 0, 3, 101, 4);
  bytes(7, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_READ), FUZZ_DELIVER_SPLIT, 0, 3, 100, 4);
  save("gaps");

  start_one(1);
  /* garbage, a false header, then packets: FF FF 01 (LENGTH 0), FF FF 01 05 ... */
  bytes(12, FUZZ_OP_PUSH_BATCH, 10, 0x00, 0xFF, 0xFF, 0x01, 0x00, 0xFF, 0xFF, 0xFF, 0x01, 0x09);
  wait(50);
  ping(OWN, BYTES);
  wait(101);
  ping(OWN, BATCH);
  save("garbage_resync");

  start_one(1);
  /* a packet started, passes 60 ms later, the rest 60 ms later */
  bytes(7, FUZZ_OP_PUSH_BATCH, 5, 0xFF, 0xFF, 0x01, 0x02, 0x01);
  wait(60);
  b(FUZZ_OP_PASS);
  wait(60);
  bytes(2, FUZZ_OP_PUSH_BYTE, 0xFB);
  /* armed PINGs whose checksum is late, the link taking empty batches meanwhile: 2, 50 and
   * 100 ms (still armed: the checksum starts the reply), 101 ms (the gap, counted from the last
   * byte, not from an empty batch, ends the packet and the armed reply) */
  bytes(4, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_PING), EARLY | FUZZ_MODE_LATE_CHECKSUM, 2);
  bytes(4, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_PING), EARLY | FUZZ_MODE_LATE_CHECKSUM, 50);
  bytes(4, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_PING), EARLY | FUZZ_MODE_LATE_CHECKSUM, 100);
  bytes(4, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_PING), EARLY | FUZZ_MODE_LATE_CHECKSUM, 101);
  ping(OWN, EARLY);
  save("empty_batch");

  start_one(1);
  write1(W, OWN, BATCH, 24, 1);
  ticks(200, 1, 512, 0, 96, 90); /* overheating: Alarm Shutdown 4 */
  ping(OWN, EARLY);
  write1(W, OWN, BATCH, 24, 1);
  ticks(10, 0, 512, 0, 40, 25); /* low voltage */
  save("alarms_heat_voltage");

  start_one(1);
  write1(W, OWN, BATCH, 18, 0x24);
  write1(W, OWN, BATCH, 24, 1);
  write2(W, OWN, EARLY, 30, 900);
  ticks(80, 1, 100, 0, 96, 25); /* stalled far from the goal: overload */
  write2(W, OWN, EARLY, 30, 100);
  ticks(50, 0, 100, 3, 96, 25);
  save("alarms_overload");

  start_one(1);
  write1(W, OWN, BATCH, 5, 10);
  eeprom(3);
  write1(W, OWN, BATCH, 5, 20);
  eeprom(2);
  cut(1, 0xFF);
  save("store_superseded_cut");

  start_blank();
  eeprom(2);
  cut(1, 0x00);
  save("blank_cut");

  b(FUZZ_START_TWO_SLOTS);
  factory_area(3);
  factory_area(4);
  bytes(2, 255, 1);
  b16(512);
  write1(W, OWN, BATCH, 3, 5);
  flush();
  cut(0, 0);
  ping(OWN, BATCH);
  save("two_slots_wrap");

  b(FUZZ_START_TWO_SLOTS);
  factory_area(3);
  factory_area(4);
  bytes(2, 10, 128); /* 128 apart: neither is ahead, slot 0 boots */
  b16(512);
  ping(OWN, BATCH);
  save("two_slots_half");

  b(FUZZ_START_TORN_SLOT);
  factory_area(6);
  factory_area(7);
  bytes(3, 20, 5, 0x10); /* slot 1 at sequence 20; the store of ID 7 cut after 5 writes */
  b16(512);
  write1(W, OWN, BATCH, 25, 1);
  write1(W, OWN, BATCH, 13, 200);
  eeprom(6);
  cut(1, 0x33);
  save("torn_slot");

  b(FUZZ_START_ONE_SLOT);
  area(254, 255, 255, 3, 2000, 1100, 1500, 200, 128); /* every item out of range: repaired */
  b16(1023);
  ping(OWN, BATCH);
  read_(OWN, BATCH, 0, 24);
  save("stored_out_of_range");

  start_one(1);
  bytes(4, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_GIVEN), BATCH, 0x92);
  bytes(5, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_GIVEN) | FUZZ_SEL_RAW_PARAMS, EARLY, 0x07, 0);
  bytes(5, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_PING) | FUZZ_SEL_RAW_PARAMS, EARLY, 1, 0);
  bytes(4, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_READ) | FUZZ_SEL_RAW_PARAMS, BATCH, 0);
  save("instruction_errors");

  start_one(1);
  /* the longest packet: LENGTH 255, a WRITE of 252 bytes (Range Error), with 3 extra 0xFF */
  bytes(5, FUZZ_OP_PACKET, FUZZ_SEL(OWN, W) | FUZZ_SEL_RAW_PARAMS, EARLY | FUZZ_MODE_EXTRA_FF(3), 253, 30);
  for (int i = 0; i < 252; i++) {
    b(0x00);
  }
  ping(OWN, BATCH);
  save("longest_packet");

  start_one(1);
  write2(W, OWN, BATCH, 6, 100);
  write2(W, OWN, BATCH, 8, 200);
  write2(W, OWN, EARLY, 30, 50); /* outside the limits: Angle Limit condition */
  ticks(20, 0, 150, 1, 96, 25);
  ping(OWN, EARLY);
  write1(W, OWN, EARLY, 26, 10);
  write1(W, OWN, EARLY, 28, 1);
  save("angle_limits");

  start_one(1);
  bytes(2, FUZZ_OP_WAIT_LONG, 0xF0);
  b(0xFF);
  ping(OWN, FUZZ_DELIVER_SPLIT);
  bytes(2, 40, 3);
  save("clock_wrap");

  start_one(4);
  write1(W, OWN, BATCH, 24, 1);
  write1(W, OWN, BATCH, 18, 0x40);
  /* RESET whose reply takes 30 ms: ticks (a 95 degC overheat) and EEPROM writes meanwhile */
  ticks(1, 0, 512, 0, 96, 95);
  bytes(4, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_RESET), BATCH | FUZZ_MODE_REPLY_TIME, 30);
  /* an unknown instruction, Alarm Shutdown 0x40: the event shuts torque down during its reply */
  write1(W, OWN, BATCH, 24, 1);
  bytes(5, FUZZ_OP_PACKET, FUZZ_SEL(OWN, FUZZ_INST_GIVEN), BATCH | FUZZ_MODE_REPLY_TIME, 0x09, 5);
  write1(W, OWN, BATCH | FUZZ_MODE_REPLY_TIME, 4, 3);
  b(12);
  save("reply_time");

  start_one(1);
  /* Protocol 2.0 frames (docs/policy.md "Framing and bus"): a 2.0 PING of ID 1 skipped whole,
   * a 2.0 frame whose data hold a whole 1.0 PING of this servo, a 2.0 header cut by a gap;
   * each followed by a 1.0 PING */
  bytes(12, FUZZ_OP_PUSH_BATCH, 10, 0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x03, 0x00, 0x01, 0x19, 0x4E);
  ping(OWN, BATCH);
  bytes(2, FUZZ_OP_PUSH_BATCH, 16);
  bytes(16, 0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x09, 0x00, 0xFF, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB, 0x00, 0x00);
  ping(OWN, BYTES);
  bytes(8, FUZZ_OP_PUSH_BATCH, 6, 0xFF, 0xFF, 0xFD, 0x00, 0x01, 0x40);
  wait(101);
  ping(OWN, EARLY);
  save("protocol2_frames");

  start_one(1);
  /* packets to this servo through the armed path after an extra leading 0xFF (the finder drops
   * it while the candidate is examined): a WRITE whose response points into the candidate,
   * a REG_WRITE, then a READ of what they wrote */
  write1(W, OWN, EARLY | FUZZ_MODE_EXTRA_FF(1), 25, 1);
  write2(R, OWN, EARLY | FUZZ_MODE_EXTRA_FF(2), 30, 700);
  bare(FUZZ_INST_ACTION, OWN, EARLY | FUZZ_MODE_EXTRA_FF(1));
  read_(OWN, EARLY | FUZZ_MODE_EXTRA_FF(3), 24, 10);
  save("early_extra_ff");

  start_one(1);
  /* a gap crossed by bytes that come before the tick of its millisecond, with a reply on the
   * wire for longer than the gap: another servo's packet (LENGTH 16) takes in a PING of this
   * servo and the first 5 bytes of a WRITE of LED 1, and the gap ends it; the rest of the WRITE
   * after the gap is no packet (docs/policy.md "Framing and bus"); then a PING whose reply
   * takes 150 ms */
  bytes(5, FUZZ_OP_PACKET, FUZZ_SEL(FUZZ_ID_NEIGHBOUR, FUZZ_INST_GIVEN) | FUZZ_SEL_RAW_PARAMS,
        FUZZ_DELIVER_SPLIT | FUZZ_MODE_REPLY_TIME, 0x00, 14);
  bytes(14, 0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB, 0xFF, 0xFF, 0x01, 0x04, 0x03, 0x19, 0x01, 0xDD);
  bytes(3, 150, 101, 16); /* the reply's 150 ms; the gap, 101 ms, after 16 of the 20 bytes */
  ping(OWN, BATCH);
  save("gap_during_reply");

  return 0;
}
