/* The fuzzed core: a libFuzzer harness that runs one servo's core behind the
 * firmware's own link layer (firmware/link/dxl_link.c and dxl_after.c) on the fake UART of the
 * host tests (test/support/fake_uart.h), from a script decoded from the input (fuzz_ops.h),
 * and checks after every operation what must always hold. A violation prints what broke and
 * aborts, so libFuzzer saves the input.
 *
 * The harness plays the board around the link, as firmware/app/main.c and the RX interrupt
 * do: bytes into the UART's receive ring (one at a time, or as many as the ring holds before
 * the link's next pass), then main-loop passes (dxl_link_service_reply, dxl_link_service_rx)
 * until the link has nothing left to do; a reply the link starts is on the wire for a time
 * the script gives (control ticks, the link's millisecond ticks and EEPROM writes run
 * meanwhile), then sent; millisecond ticks (dxl_link_tick, the control tick,
 * dxl_link_conditions_changed); the RX interrupt's sniff for a packet it would arm (the
 * fake's sniff started by the link, all but the checksum held in the ring, the reply armed,
 * the checksum at once or some milliseconds late); the EEPROM writer of nvm.c
 * (test/support/eeprom_model.h) stepped by the script, cut at any byte (the byte being
 * written left at any value) and the servo powered up again from what is stored.
 *
 * It sees each packet as the link hands it to the servo: the linker wraps
 * dxl_servo_prepare and dxl_servo_reject_checksum (-Wl,--wrap, harness/CMakeLists.txt), so
 * the servo is copied as the packet finds it, and dxl_finder_poll, so the reference finder is
 * polled when the link polls its finder; the fake's hooks report the bytes the link takes,
 * the packet handled (and the reply the UART sends for it), every store and every new baud. A packet's checks run once what follows it has run: after its reply has left and
 * dxl_link_service_reply has run, or, without a reply, when the link goes on to another
 * packet or is idle.
 *
 * Invariants (docs/policy.md sections in quotes):
 *   - framing: the reference finder (ref_finder.h), fed the same bytes at the same times and
 *     polled with the link's finder, reports the same packets and bad checksums in the same
 *     order, and nothing more once the link is idle ("Framing and bus");
 *   - replies: a reply only where "Replies" says one is due (ID, broadcast, Status Return
 *     Level, as the servo was before the packet), a well-formed status packet of the old ID
 *     with a correct checksum, LENGTH 2, or 2 + n for a READ of n bytes, whose data are the
 *     table's; its event bits are the packet's, its condition bits those held (the Angle
 *     Limit condition kept by the harness: "Goal Position and the angle limits"); the Return
 *     Delay Time is the old one; dxl_servo_answers() and dxl_servo_ping_reply() agree with it;
 *   - another servo's packet (or a bad checksum of one, or a broadcast one) changes nothing
 *     and stores nothing;
 *   - a packet with an event error (range, instruction, checksum: "Instructions and their
 *     errors") changes nothing but the pending events, and stores nothing;
 *   - what each instruction does when it succeeds: WRITE, SYNC_WRITE (this servo's first
 *     slice, when the slices fit), REG_WRITE, ACTION and RESET change exactly their bytes; the
 *     EEPROM area is stored, and the baud set again, exactly when written;
 *   - Lock: while set, a packet changes no locked address and stores nothing ("Lock");
 *   - ranges: every writable item inside its range (ct_items.h; Moving Speed up to 2047 in
 *     wheel mode) after every packet and every control tick; a tick changes only the Present
 *     items, Moving, and Torque Enable / Torque Limit to 0 (shutdown);
 *   - alarms ("Alarms"): after a tick the voltage and overheating conditions are those of the
 *     sensors against the limits; torque goes off exactly when an alarm selected by Alarm
 *     Shutdown holds (profile ax12a: Torque Limit 0 too); no drive with torque off;
 *   - the reply on the wire is the one the servo prepared (bytes, length, Return Delay
 *     Time), and there is one exactly when the servo prepared one;
 *   - the armed path: the packet the link prepares before the checksum is the one on the
 *     wire, its reply is published before the checksum comes and obeys dxl_servo.h "Streamed
 *     replies", and what the link commits (or, for a PING, the ready reply the UART sends) is
 *     what the complete packet gives;
 *   - the link takes every byte: none is left in the ring once it is idle;
 *   - EEPROM: whenever no store is under way, the stored settings (repaired as at power-up)
 *     are the table's EEPROM area; after a cut and a power-up the settings read are the last
 *     completely stored ones or the ones being stored, and factory defaults (no valid slot)
 *     only if nothing was ever stored ("Power-up", docs/hardware.md "EEPROM image").
 */
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dxl_after.h"
#include "dxl_control.h"
#include "dxl_image.h"
#include "dxl_link.h"
#include "dxl_link_port.h"
#include "dxl_packet.h"
#include "dxl_protocol.h"
#include "dxl_servo.h"
#include "dxl_table.h"
#include "eeprom_model.h"
#include "fake_uart.h"
#include "fuzz_ops.h"
#include "item_ranges.h"
#include "ref_finder.h"

/* Bounds that keep one input's run short. */
#define MAX_OPS 400u
#define PRESENT_POSITION_MAX 1023u
#define MOVING_SPEED_WHEEL_MAX 2047u
#define CT_PRESENT_FIRST CT_ADDR_PRESENT_POSITION /* 36..43: Present items, written by the tick */

/* The fake UART's receive ring: 256 slots with 8-bit indices, one always free. */
#define RING_CAPACITY 255u
/* The longest packet the RX interrupt's sniff frames and may arm: UART_SNIFF_MAX_LENGTH in
 * firmware/hal/uart.h (docs/firmware.md "Receive"); a longer one is the finder's. */
#define SNIFF_MAX_LENGTH 96u
/* Main-loop passes one batch of bytes may take before the link is idle: far above what any
 * batch needs (a pass per rejected candidate, one per reply), so a link that keeps asking for
 * passes is caught. */
#define MAX_PASSES 100000u
/* The EEPROM writer's pace while a reply is on the wire: a write every 4 ms (nvm.c: 3.4 ms a
 * byte). */
#define EEPROM_WRITE_EVERY_MS 4u

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* ---------------------------------------------------------------------------------------
 * Failure
 * --------------------------------------------------------------------------------------- */

static size_t op_index;

static void fail(const char *format, ...) __attribute__((format(printf, 1, 2), noreturn));
static void fail(const char *format, ...) {
  va_list args;
  va_start(args, format);
  fprintf(stderr, "fuzz_core (" AX12_PROFILE_NAME "): invariant broken at operation %zu: ", op_index);
  vfprintf(stderr, format, args);
  fputc('\n', stderr);
  va_end(args);
  abort();
}

/* ---------------------------------------------------------------------------------------
 * Input
 * --------------------------------------------------------------------------------------- */

typedef struct {
  const uint8_t *bytes;
  size_t left;
} input_t;

static uint8_t take(input_t *in) {
  if (in->left == 0) {
    return 0;
  }
  in->left--;
  return *in->bytes++;
}

static uint16_t take16(input_t *in) {
  const uint8_t low = take(in);
  return (uint16_t)(low | ((uint16_t)take(in) << 8));
}

/* ---------------------------------------------------------------------------------------
 * The servo as the firmware runs it
 * --------------------------------------------------------------------------------------- */

/* A packet as framed (FF FF ID LENGTH ... CHECKSUM), copied out of the finder: packet.params
 * points into bytes. */
typedef struct {
  dxl_packet_t packet;
  uint8_t bytes[DXL_PACKET_MAX_BYTES];
} framed_t;

/* The servo as the link's next packet finds it, and the board's counts then. */
typedef struct {
  bool valid; /* taken since the last packet handled */
  dxl_servo_t servo;
  unsigned persists;
  unsigned baud_sets;
} before_t;

/* A packet handled whose effects are not all in yet: what follows its reply runs once the
 * reply has left; without a reply, at once after the link reports it. */
typedef struct {
  bool open;
  bool replied;
  bool ticked; /* control ticks ran since it was handled */
  before_t before;
  framed_t framed;
  dxl_response_t response; /* what the servo made of it; bytes: the reply on the wire */
} handled_t;

/* The RX interrupt's sniff as the harness plays it for one packet. */
typedef enum {
  SNIFF_IDLE,    /* not armed: every packet reaches the link through the finder */
  SNIFF_ARMED,   /* armed at the packet's last byte but one; its checksum is still to come */
  SNIFF_MATCHED, /* its checksum came, matched, and started the armed reply */
} sniff_play_t;

typedef struct {
  ref_finder_t ref;
  dxl_servo_t servo;
  dxl_link_t link;
  fake_uart_t uart; /* now_us: the clock */
  dxl_control_t control;
  dxl_sensors_t sensors;
  eeprom_model_t eeprom;
  /* The settings a power-up may find: the last completely stored (and the ones before it when
   * the write of its sequence number was cut). Persisted settings wait (latest) until a store
   * takes them (under_way), which never restarts: nvm.c's write policy. */
  bool have_stored;
  uint8_t stored[CT_EEPROM_SIZE];
  bool have_prior;
  uint8_t prior[CT_EEPROM_SIZE];
  bool have_under_way;
  uint8_t under_way[CT_EEPROM_SIZE];
  bool have_latest;
  uint8_t latest[CT_EEPROM_SIZE];
  unsigned persists; /* stores started */
  /* docs/policy.md "Goal Position and the angle limits", kept here apart from the core: in
   * wheel mode, whether a Goal Position was written since wheel mode began. */
  bool wheel_goal_written;
  unsigned baud_sets; /* dxl_after_port_set_baud calls */
  unsigned reply_ms; /* how long a reply takes on the wire (PACKET mode bit 5), 0: no time */
  before_t before;
  handled_t handled;
  sniff_play_t sniff;
  const dxl_packet_t *sniffed; /* the packet the sniff armed, as sent */
} world_t;

static world_t world;

static uint16_t now_ms(world_t *w) { return dxl_link_port_now_ms(&w->uart); }

static void pass_ms(world_t *w, uint32_t ms) { w->uart.now_us += (uint64_t)ms * 1000u; }

/* ---------------------------------------------------------------------------------------
 * Table invariants
 * --------------------------------------------------------------------------------------- */

/* items[], ITEM_COUNT: item_ranges.h */

static uint16_t item_value(const uint8_t *table, const item_t *item) {
  return item->size == 2 ? ct_get_u16(table, item->addr) : table[item->addr];
}

static void check_ranges(const uint8_t *table, const char *when) {
  const bool wheel = ct_get_u16(table, CT_ADDR_CW_ANGLE_LIMIT) == 0 && ct_get_u16(table, CT_ADDR_CCW_ANGLE_LIMIT) == 0;
  for (size_t i = 0; i < sizeof items / sizeof items[0]; i++) {
    const item_t *item = &items[i];
    const uint16_t value = item_value(table, item);
    uint16_t min = item->min;
    uint16_t max = item->max;
    if (item->addr == CT_ADDR_MOVING_SPEED && wheel) {
      max = MOVING_SPEED_WHEEL_MAX;
    }
    if (item->addr == CT_ADDR_LOCK || item->addr == CT_ADDR_REGISTERED_INSTRUCTION) {
      min = 0; /* Lock reads 0 until written 1; Registered Instruction is 0 or 1 in both profiles */
      max = 1;
    }
    if (item->access == CT_NONE && value != 0) {
      fail("%s: reserved %s (address %u) holds %u", when, item->name, item->addr, value);
    }
    if (item->access == CT_RW && (value < min || value > max)) {
      fail("%s: %s (address %u) holds %u, outside %u..%u%s", when, item->name, item->addr, value, min, max,
           wheel ? " (wheel mode)" : "");
    }
  }
}

/* The EEPROM area a power-up makes of stored bytes (docs/policy.md "Power-up"). */
static void repaired(const uint8_t *stored, uint8_t out[CT_SIZE]) {
  memset(out, 0, CT_SIZE); /* Lock off: ct_repair_stored_eeprom's precondition */
  memcpy(out, stored, CT_EEPROM_SIZE);
  ct_repair_stored_eeprom(out);
}

/* While no store is under way, what is stored is what runs. */
static void check_eeprom_idle(const world_t *w, const char *when) {
  if (eeprom_model_busy(&w->eeprom)) {
    return;
  }
  const uint8_t *stored = dxl_image_settings(w->eeprom.image);
  if (stored == NULL) {
    fail("%s: no store under way and no valid settings stored", when);
  }
  uint8_t expected[CT_SIZE];
  repaired(stored, expected);
  if (memcmp(expected, w->servo.table, CT_EEPROM_SIZE) != 0) {
    for (uint8_t a = 0; a < CT_EEPROM_SIZE; a++) {
      if (expected[a] != w->servo.table[a]) {
        fail("%s: no store under way, but the stored settings differ at address %u (stored %u, table %u)", when, a,
             expected[a], w->servo.table[a]);
      }
    }
  }
}

/* Whether a control tick may have changed address a (control_tick() checks how). */
static bool tick_may_change(uint8_t a) {
  return a == CT_ADDR_TORQUE_ENABLE || a == CT_ADDR_TORQUE_LIMIT || a == CT_ADDR_TORQUE_LIMIT + 1 ||
         (a >= CT_PRESENT_FIRST && a <= CT_ADDR_PRESENT_TEMPERATURE) || a == CT_ADDR_MOVING;
}

/* Tables equal, but where control ticks ran in between (ticked) at the addresses they write. */
static bool tables_equal(const uint8_t *a, const uint8_t *b, bool ticked) {
  for (uint8_t addr = 0; addr < CT_SIZE; addr++) {
    if (a[addr] != b[addr] && !(ticked && tick_may_change(addr))) {
      return false;
    }
  }
  return true;
}

/* Servos equal; with ticked, control ticks ran in between: the addresses they write, the held
 * conditions and the pending events (which they take) are left out. */
static bool servo_equal(const dxl_servo_t *a, const dxl_servo_t *b, bool compare_events, bool ticked) {
  return tables_equal(a->table, b->table, ticked) && a->reg_start == b->reg_start && a->reg_len == b->reg_len &&
         memcmp(a->reg_data, b->reg_data, a->reg_len <= DXL_REG_SLOT_BYTES ? a->reg_len : DXL_REG_SLOT_BYTES) == 0 &&
         a->goal_written_in_wheel_mode == b->goal_written_in_wheel_mode &&
         (ticked || a->held_conditions == b->held_conditions) &&
         (ticked || !compare_events || a->pending_events == b->pending_events);
}

static void describe_table_difference(const uint8_t *before, const uint8_t *after, char *out, size_t size) {
  out[0] = '\0';
  for (uint8_t a = 0; a < CT_SIZE; a++) {
    if (before[a] != after[a]) {
      snprintf(out, size, "address %u: %u -> %u", a, before[a], after[a]);
      return;
    }
  }
  snprintf(out, size, "outside the table (REG_WRITE slot, flags or events)");
}

/* ---------------------------------------------------------------------------------------
 * The packet oracle: what a packet must and may do, from docs/policy.md
 * --------------------------------------------------------------------------------------- */

/* Writes data[0..len) at start into table as a WRITE does (docs/policy.md "WRITE, REG_WRITE
 * and ACTION", "Motion semantics"): address 44 written 0 clears it, written 1 leaves it; in
 * joint mode afterwards Moving Speed keeps bits 0..9 only (leaving wheel mode drops the
 * direction); then Moving and Present Load as a committed write leaves them: with torque off
 * both 0, with torque on Moving 1 when the goal (clamped to the limits) lies farther from
 * Present Position than the margin on its side + 2, or a wheel-mode speed Torque Limit lets
 * through. */
static void apply_window(uint8_t *table, uint8_t start, const uint8_t *data, uint8_t len) {
  for (uint8_t i = 0; i < len; i++) {
    const unsigned addr = (unsigned)start + i;
    if (addr >= CT_SIZE) {
      fail("a successful write reaches address %u", addr);
    }
    if (addr == CT_ADDR_REGISTERED_INSTRUCTION) {
      if (data[i] == 0) {
        table[addr] = 0;
      }
      continue;
    }
    table[addr] = data[i];
  }
  const bool wheel = ct_get_u16(table, CT_ADDR_CW_ANGLE_LIMIT) == 0 && ct_get_u16(table, CT_ADDR_CCW_ANGLE_LIMIT) == 0;
  const uint16_t speed = ct_get_u16(table, CT_ADDR_MOVING_SPEED);
  if (!wheel) {
    ct_set_u16(table, CT_ADDR_MOVING_SPEED, (uint16_t)(speed & 0x3FFu));
  }
  if (table[CT_ADDR_TORQUE_ENABLE] == 0) {
    table[CT_ADDR_MOVING] = 0;
    ct_set_u16(table, CT_ADDR_PRESENT_LOAD, 0);
    return;
  }
  bool starts;
  if (wheel) {
    const uint16_t torque_limit = ct_get_u16(table, CT_ADDR_TORQUE_LIMIT);
    starts = (speed & 0x3FFu) != 0 && torque_limit != 0;
  } else {
    const int cw = ct_get_u16(table, CT_ADDR_CW_ANGLE_LIMIT);
    const int ccw = ct_get_u16(table, CT_ADDR_CCW_ANGLE_LIMIT);
    int goal = ct_get_u16(table, CT_ADDR_GOAL_POSITION);
    goal = goal < cw ? cw : goal > ccw ? ccw : goal;
    const int error = goal - (int)ct_get_u16(table, CT_ADDR_PRESENT_POSITION);
    const int margin = error > 0 ? table[CT_ADDR_CW_COMPLIANCE_MARGIN] : table[CT_ADDR_CCW_COMPLIANCE_MARGIN];
    starts = (error < 0 ? -error : error) > margin + 2;
  }
  if (starts) {
    table[CT_ADDR_MOVING] = 1;
  }
}

/* docs/policy.md "Replies": whether a good packet is answered, from the servo before it. */
static bool reply_due(const uint8_t *table, uint8_t id, uint8_t instruction) {
  if (id == DXL_ID_BROADCAST) {
    return DXL_PROFILE == DXL_PROFILE_AX12 && instruction == DXL_INST_PING;
  }
  if (id != table[CT_ADDR_ID]) {
    return false;
  }
  const uint8_t level = table[CT_ADDR_STATUS_RETURN_LEVEL];
  return instruction == DXL_INST_PING || (instruction == DXL_INST_READ && level >= 1) || level >= 2;
}

/* The events a good packet to this servo (or broadcast) must raise when they follow from its
 * shape alone; *maybe_range is set where a Range Error depends on the values. */
static uint8_t expected_events(const dxl_servo_t *s, const dxl_packet_t *p, bool *maybe_range) {
  const uint8_t n = p->param_count;
  *maybe_range = false;
  switch (p->instruction) {
  case DXL_INST_PING:
    return n == 0 ? 0 : DXL_ERR_INSTRUCTION;
  case DXL_INST_READ:
    if (n != 2) {
      return DXL_ERR_INSTRUCTION;
    }
    return (p->params[1] == 0 || (unsigned)p->params[0] + p->params[1] > CT_SIZE) ? DXL_ERR_RANGE : 0;
  case DXL_INST_WRITE:
  case DXL_INST_REG_WRITE:
    if (n < 2) {
      return DXL_ERR_INSTRUCTION;
    }
    *maybe_range = true;
    return 0;
  case DXL_INST_ACTION:
    if (n != 0 || s->table[CT_ADDR_REGISTERED_INSTRUCTION] == 0) {
      return DXL_ERR_INSTRUCTION;
    }
    *maybe_range = true;
    return 0;
  case DXL_INST_RESET:
    return (n != 0 || s->table[CT_ADDR_LOCK] != 0) ? DXL_ERR_INSTRUCTION : 0;
  case DXL_INST_SYNC_WRITE:
    if (n < 2 || p->id != DXL_ID_BROADCAST) {
      return DXL_ERR_INSTRUCTION;
    }
    *maybe_range = true;
    return 0;
  default:
    return DXL_ERR_INSTRUCTION;
  }
}

/* docs/policy.md "SYNC_WRITE": this servo's first slice, when the slices fill the packet. */
static bool own_sync_slice(const dxl_packet_t *p, uint8_t own_id, const uint8_t **slice, uint8_t *len) {
  const unsigned l = p->params[1];
  const unsigned slices_bytes = p->param_count - 2u;
  if (l == 0 || slices_bytes == 0 || slices_bytes % (l + 1u) != 0) {
    return false;
  }
  for (unsigned ofs = 2; ofs < p->param_count; ofs += l + 1u) {
    if (p->params[ofs] == own_id) {
      *slice = &p->params[ofs + 1u];
      *len = (uint8_t)l;
      return true;
    }
  }
  return false;
}

static void check_status_packet(const dxl_response_t *r, uint8_t id, const char *what) {
  if (r->length < 6 || r->length > DXL_REPLY_MAX_BYTES) {
    fail("%s: reply of %u bytes", what, r->length);
  }
  const uint8_t *b = r->bytes;
  if (b[0] != DXL_HEADER_BYTE || b[1] != DXL_HEADER_BYTE) {
    fail("%s: reply header %02X %02X", what, b[0], b[1]);
  }
  if (b[2] != id) {
    fail("%s: reply from ID %u, the servo's ID was %u", what, b[2], id);
  }
  if (b[3] + 4u != r->length) {
    fail("%s: reply LENGTH %u in %u bytes", what, b[3], r->length);
  }
  if (dxl_checksum(&b[2], (uint16_t)(r->length - 3u)) != b[r->length - 1u]) {
    fail("%s: reply checksum wrong", what);
  }
  if (b[DXL_STATUS_ERROR_OFFSET] & 0x80u) {
    fail("%s: error byte bit 7 set", what);
  }
}

static unsigned written_window(const dxl_servo_t *before, const dxl_packet_t *p, unsigned *start);

/* Checks a packet's reply and effects. before: the servo before it; persists_before: the
 * store count before it. */
static void check_packet(const world_t *w, const dxl_servo_t *before, unsigned persists_before,
                         unsigned baud_sets_before, const dxl_packet_t *p, const dxl_response_t *r,
                         uint8_t pending_before, bool ticked) {
  const dxl_servo_t *after = &w->servo;
  const uint8_t old_id = before->table[CT_ADDR_ID];
  const bool addressed = p->id == old_id || p->id == DXL_ID_BROADCAST;
  const bool stored = w->persists != persists_before;
  const bool baud_set = w->baud_sets != baud_sets_before;
  char diff[96];
  char what[96];
  snprintf(what, sizeof what, "packet ID %u instruction 0x%02X with %u parameters", p->id, p->instruction,
           p->param_count);

  check_ranges(after->table, what);

  /* The reply. */
  if (reply_due(before->table, p->id, p->instruction) != (r->length != 0)) {
    fail("%s: %s (Status Return Level %u, servo ID %u)", what, r->length != 0 ? "answered" : "not answered",
         before->table[CT_ADDR_STATUS_RETURN_LEVEL], old_id);
  }
  if (dxl_servo_answers(before, p->id, p->instruction) != (r->length != 0)) {
    fail("%s: dxl_servo_answers disagrees with the reply", what);
  }
  if (!addressed) {
    if (!servo_equal(before, after, true, false) || stored || baud_set || r->after != 0 || r->events != 0) {
      describe_table_difference(before->table, after->table, diff, sizeof diff);
      fail("%s: another servo's packet changed something (%s)%s", what, diff, stored ? ", stored" : "");
    }
    return;
  }
  bool maybe_range;
  const uint8_t must = expected_events(before, p, &maybe_range);
  if (r->events != must && !(maybe_range && must == 0 && r->events == DXL_ERR_RANGE)) {
    fail("%s: events 0x%02X, expected 0x%02X%s", what, r->events, must, maybe_range ? " or a Range Error" : "");
  }
  if (r->length != 0) {
    check_status_packet(r, old_id, what);
    const uint8_t error = r->bytes[DXL_STATUS_ERROR_OFFSET];
    if ((error & DXL_ERR_EVENTS) != r->events) {
      fail("%s: reply error 0x%02X, events 0x%02X", what, error, r->events);
    }
    const uint8_t held = DXL_ERR_VOLTAGE | DXL_ERR_OVERHEATING | DXL_ERR_OVERLOAD;
    if ((error & held) != (before->held_conditions & held)) {
      fail("%s: reply error 0x%02X, held conditions 0x%02X", what, error, before->held_conditions);
    }
    if (r->delay_us != DXL_RETURN_DELAY_UNIT_US * before->table[CT_ADDR_RETURN_DELAY_TIME]) {
      fail("%s: reply delay %u us at Return Delay Time %u", what, r->delay_us,
           before->table[CT_ADDR_RETURN_DELAY_TIME]);
    }
    const bool read_ok = p->instruction == DXL_INST_READ && r->events == 0;
    const unsigned expected_length = 6u + (read_ok ? p->params[1] : 0u);
    if (r->length != expected_length) {
      fail("%s: reply of %u bytes, %u asked", what, r->length, expected_length);
    }
    if (read_ok && memcmp(&r->bytes[5], &before->table[p->params[0]], p->params[1]) != 0) {
      fail("%s: READ data are not the table's", what);
    }
    if (p->instruction == DXL_INST_PING && p->param_count == 0) {
      dxl_response_t ready;
      memset(&ready, 0, sizeof ready);
      dxl_servo_ping_reply(before, &ready);
      if (ready.length != r->length || memcmp(ready.bytes, r->bytes, r->length) != 0 ||
          ready.delay_us != r->delay_us) {
        fail("%s: dxl_servo_ping_reply differs from the PING's prepared reply", what);
      }
    }
  }

  /* Errors change nothing (docs/policy.md "Instructions and their errors"). */
  if (r->events != 0) {
    if (!servo_equal(before, after, false, ticked) || stored || baud_set) {
      describe_table_difference(before->table, after->table, diff, sizeof diff);
      fail("%s: error 0x%02X but something changed (%s)%s", what, r->events, diff, stored ? ", stored" : "");
    }
    if (!ticked && after->pending_events != (uint8_t)(pending_before | r->events)) {
      fail("%s: pending events 0x%02X after 0x%02X with events 0x%02X", what, after->pending_events,
           pending_before, r->events);
    }
    return;
  }

  /* Lock (docs/policy.md "Lock"). */
  if (before->table[CT_ADDR_LOCK] != 0) {
    if (after->table[CT_ADDR_LOCK] != 1 || stored) {
      fail("%s: while locked, Lock reads %u%s", what, after->table[CT_ADDR_LOCK], stored ? ", stored" : "");
    }
    for (uint8_t a = 0; a < CT_SIZE; a++) {
#if DXL_PROFILE == DXL_PROFILE_AX12A
      const bool locked_addr = a >= CT_ADDR_ID && a < CT_EEPROM_SIZE;
#else
      /* the items Lock refuses: all but 24..35, less what instructions change by themselves
       * (Registered Instruction: REG_WRITE and ACTION; Present Load and Moving: a committed
       * write), which the instruction check below covers */
      const bool locked_addr = a < CT_ADDR_TORQUE_ENABLE || a == CT_ADDR_RESERVED_45 || a >= CT_ADDR_LOCK;
#endif
      if (locked_addr && before->table[a] != after->table[a] && !(ticked && tick_may_change(a))) {
        fail("%s: while locked, address %u changed %u -> %u", what, a, before->table[a], after->table[a]);
      }
    }
  }

  /* What the instruction does; the baud is set again after a write of address 4 or RESET,
   * and only then ("Replies": after the reply). */
  uint8_t expected[CT_SIZE];
  memcpy(expected, before->table, CT_SIZE);
  bool expect_store = false;
  unsigned window_start = 0;
  const unsigned window_len = written_window(before, p, &window_start);
  bool expect_baud = window_len != 0 && window_start <= CT_ADDR_BAUD_RATE && window_start + window_len > CT_ADDR_BAUD_RATE;
  switch (p->instruction) {
  case DXL_INST_WRITE:
    apply_window(expected, p->params[0], &p->params[1], (uint8_t)(p->param_count - 1u));
    expect_store = p->params[0] < CT_EEPROM_SIZE;
    break;
  case DXL_INST_REG_WRITE:
    expected[CT_ADDR_REGISTERED_INSTRUCTION] = 1;
    if (after->reg_start != p->params[0] || after->reg_len != p->param_count - 1u ||
        memcmp(after->reg_data, &p->params[1], after->reg_len) != 0) {
      fail("%s: the REG_WRITE slot does not hold the window", what);
    }
    break;
  case DXL_INST_ACTION:
    expected[CT_ADDR_REGISTERED_INSTRUCTION] = 0;
    apply_window(expected, before->reg_start, before->reg_data, before->reg_len);
    expected[CT_ADDR_REGISTERED_INSTRUCTION] = 0;
    expect_store = before->reg_start < CT_EEPROM_SIZE;
    break;
  case DXL_INST_RESET: {
    dxl_servo_t fresh;
    /* the present position as the reset found it (ticks may have run during the reply) */
    dxl_servo_power_up(&fresh, NULL, ct_get_u16(after->table, CT_ADDR_PRESENT_POSITION));
    memcpy(expected, fresh.table, CT_SIZE);
    expect_store = true;
    expect_baud = true;
    break;
  }
  case DXL_INST_SYNC_WRITE: {
    const uint8_t *slice = NULL;
    uint8_t len = 0;
    if (own_sync_slice(p, old_id, &slice, &len)) {
      apply_window(expected, p->params[0], slice, len);
      expect_store = p->params[0] < CT_EEPROM_SIZE;
    }
    break;
  }
  default: /* PING, READ */
    break;
  }
  if (!tables_equal(expected, after->table, ticked)) {
    describe_table_difference(expected, after->table, diff, sizeof diff);
    fail("%s: the table is not what the instruction writes (expected -> found at %s)", what, diff);
  }
  if (baud_set != expect_baud) {
    fail("%s: %s", what, baud_set ? "the baud was set again without a write of it" : "Baud Rate written, not applied");
  }
  if (stored != expect_store) {
    fail("%s: %s", what, stored ? "stored the settings without writing the EEPROM area" : "EEPROM area written, not stored");
  }
  if (!ticked && p->instruction != DXL_INST_RESET && after->pending_events != pending_before) {
    fail("%s: pending events changed without an error", what);
  }
}


/* One nvm_service() with the EEPROM ready (torn: the byte it writes is cut, eeprom_model.h),
 * following which settings a power-up may find. Returns whether it wrote a byte. */
static bool service_store(world_t *w, const uint8_t *torn) {
  if (w->eeprom.steps_left == 0 && w->eeprom.pending) { /* a store of the latest starts */
    memcpy(w->under_way, w->latest, CT_EEPROM_SIZE);
    w->have_under_way = true;
    w->have_latest = false;
  }
  const bool wrote = eeprom_model_service(&w->eeprom, torn);
  w->have_prior = false;
  if (w->have_under_way && w->eeprom.steps_left == 0) { /* its sequence number is in */
    w->have_prior = torn != NULL && w->have_stored; /* unless that write was cut */
    memcpy(w->prior, w->stored, CT_EEPROM_SIZE);
    memcpy(w->stored, w->under_way, CT_EEPROM_SIZE);
    w->have_stored = true;
    w->have_under_way = false;
  }
  return wrote;
}

/* Services until every persisted setting is stored. */
static void flush_store(world_t *w) {
  while (eeprom_model_busy(&w->eeprom)) {
    (void)service_store(w, NULL);
  }
}

static bool wheel_mode(const uint8_t *table) {
  return ct_get_u16(table, CT_ADDR_CW_ANGLE_LIMIT) == 0 && ct_get_u16(table, CT_ADDR_CCW_ANGLE_LIMIT) == 0;
}

/* The Angle Limit condition of a table: the goal outside CW..CCW, or in wheel mode a goal
 * written since wheel mode began. */
static bool angle_condition(const world_t *w, const uint8_t *table) {
  if (wheel_mode(table)) {
    return w->wheel_goal_written;
  }
  const uint16_t goal = ct_get_u16(table, CT_ADDR_GOAL_POSITION);
  return goal < ct_get_u16(table, CT_ADDR_CW_ANGLE_LIMIT) || goal > ct_get_u16(table, CT_ADDR_CCW_ANGLE_LIMIT);
}

/* The window a committed packet without an error wrote (length 0: none), from the packet
 * (and for ACTION the slot, whose contents check_packet verified at its REG_WRITE). */
static unsigned written_window(const dxl_servo_t *before, const dxl_packet_t *p, unsigned *start) {
  const uint8_t *slice;
  uint8_t len;
  switch (p->instruction) {
  case DXL_INST_WRITE:
    *start = p->params[0];
    return p->param_count - 1u;
  case DXL_INST_ACTION:
    *start = before->reg_start;
    return before->reg_len;
  case DXL_INST_SYNC_WRITE:
    if (own_sync_slice(p, before->table[CT_ADDR_ID], &slice, &len)) {
      *start = p->params[0];
      return len;
    }
    return 0;
  default:
    return 0;
  }
}

/* The wheel-mode goal flag after a packet took the table from before to after. */
static void update_wheel_goal(world_t *w, const uint8_t *before, const uint8_t *after, unsigned start,
                              unsigned len) {
  if (!wheel_mode(after)) {
    w->wheel_goal_written = false;
  } else if (len != 0 && start <= CT_ADDR_GOAL_POSITION + 1u && start + len > CT_ADDR_GOAL_POSITION) {
    w->wheel_goal_written = true;
  } else if (!wheel_mode(before)) {
    w->wheel_goal_written = false; /* entering wheel mode with an old goal does not raise it */
  }
}

static void check_angle_condition(const world_t *w, const char *when) {
  const bool expected = angle_condition(w, w->servo.table);
  if (((dxl_servo_conditions(&w->servo) & DXL_ERR_ANGLE_LIMIT) != 0) != expected) {
    fail("%s: the core's Angle Limit condition is %s, the policy's %s", when, expected ? "off" : "on",
         expected ? "on" : "off");
  }
}

/* ---------------------------------------------------------------------------------------
 * The board around the link (fake_uart.h hooks; context: the world)
 * --------------------------------------------------------------------------------------- */

/* A store: the EEPROM writer of nvm.c takes the settings over. */
static void store_settings(world_t *w, const uint8_t *table) {
  eeprom_model_persist(&w->eeprom, table);
  memcpy(w->latest, table, CT_EEPROM_SIZE);
  w->have_latest = true;
  w->persists++;
}

static void on_store(void *context, const uint8_t *table) { store_settings(context, table); }

static void on_baud(void *context, uint8_t baud_register) {
  world_t *w = context;
  if (baud_register != w->servo.table[CT_ADDR_BAUD_RATE]) {
    fail("set_baud(%u) while the Baud Rate register holds %u", baud_register, w->servo.table[CT_ADDR_BAUD_RATE]);
  }
  w->baud_sets++;
}

/* The bytes the link moves from the ring into its finder reach the reference finder at the
 * same moment, after a poll (dxl_finder_push_slot polls the gap first, an empty batch too). */
static void on_take(void *context, const uint8_t *bytes, uint8_t count) {
  world_t *w = context;
  const uint16_t ms = now_ms(w);
  ref_finder_poll(&w->ref, ms);
  for (uint8_t i = 0; i < count; i++) {
    if (!ref_finder_push(&w->ref, bytes[i], ms)) {
      fail("the reference finder is full");
    }
  }
}

/* ---------------------------------------------------------------------------------------
 * The link's packets, seen as it hands them to the servo
 * --------------------------------------------------------------------------------------- */

static void compare_with_reference(world_t *w, dxl_find_result_t found, const dxl_packet_t *p) {
  ref_packet_t ref;
  const dxl_find_result_t expected = ref_finder_next(&w->ref, &ref);
  if (found != expected) {
    fail("the finder says %d, the reference finder %d (reference: ID %u instruction 0x%02X, %u parameters)", found,
         expected, ref.id, ref.instruction, ref.param_count);
  }
  if (found == DXL_FIND_NONE) {
    return;
  }
  if (p->id != ref.id || p->instruction != ref.instruction || p->param_count != ref.param_count ||
      p->checksum != ref.checksum || memcmp(p->params, ref.params, p->param_count) != 0) {
    fail("the finder's packet (ID %u instruction 0x%02X, %u parameters) is not the reference finder's (ID %u "
         "instruction 0x%02X, %u parameters)",
         p->id, p->instruction, p->param_count, ref.id, ref.instruction, ref.param_count);
  }
}

static bool same_packet(const dxl_packet_t *a, const dxl_packet_t *b) {
  return a->id == b->id && a->instruction == b->instruction && a->param_count == b->param_count &&
         memcmp(a->params, b->params, a->param_count) == 0;
}

static void frame(const uint8_t *bytes, uint16_t length, framed_t *out) {
  if (length < 6u || length > DXL_PACKET_MAX_BYTES || length != 4u + bytes[3]) {
    fail("a packet handled as %u bytes with LENGTH %u", length, length >= 4u ? bytes[3] : 0u);
  }
  memcpy(out->bytes, bytes, length);
  out->packet.id = bytes[2];
  out->packet.param_count = (uint8_t)(bytes[3] - 2u);
  out->packet.instruction = bytes[4];
  out->packet.params = &out->bytes[5];
  out->packet.checksum = bytes[length - 1u];
}

/* The checks of a packet once what follows it has run. */
static void finish_handled(world_t *w) {
  handled_t *h = &w->handled;
  if (!h->open) {
    return;
  }
  h->open = false;
  const dxl_servo_t *before = &h->before.servo;
  if (h->response.after & DXL_AFTER_FACTORY_RESET) {
    w->wheel_goal_written = false;
  }
  check_packet(w, before, h->before.persists, h->before.baud_sets, &h->framed.packet, &h->response,
               before->pending_events, h->ticked);
  check_angle_condition(w, "after a packet");
  if (w->persists != h->before.persists || memcmp(before->table, w->servo.table, CT_EEPROM_SIZE) != 0) {
    check_eeprom_idle(w, "after a packet"); /* else as it was before the packet */
  }
}

/* The link hands a packet to the servo: the packet before it is complete (the link takes the
 * next only once a reply has left), and the servo is copied as this one finds it. */
static void packet_begins(world_t *w, const dxl_servo_t *servo) {
  if (w->handled.open) {
    if (w->handled.replied) {
      fail("a packet handed to the servo while the reply of the one before is on the wire");
    }
    finish_handled(w);
  }
  w->before.valid = true;
  memcpy(&w->before.servo, servo, sizeof w->before.servo);
  w->before.persists = w->persists;
  w->before.baud_sets = w->baud_sets;
}

/* The armed path's prepare, while the checksum is still on the wire: the finder's candidate is
 * the packet the sniff armed, and its reply can be streamed (dxl_servo.h "Streamed replies"). */
static void check_armed_prepare(const world_t *w, const dxl_packet_t *candidate, const dxl_response_t *r) {
  if (!same_packet(candidate, w->sniffed)) {
    fail("the candidate before the checksum (ID %u instruction 0x%02X, %u parameters) is not the packet on the wire",
         candidate->id, candidate->instruction, candidate->param_count);
  }
  if (r->length == 0 || dxl_after_waits_for_reply(r->after) || r->bytes[0] != DXL_HEADER_BYTE ||
      r->bytes[1] != DXL_HEADER_BYTE || r->bytes[2] != w->servo.table[CT_ADDR_ID]) {
    fail("a streamed packet (instruction 0x%02X) breaks the stream contract: reply of %u bytes, after 0x%02X",
         candidate->instruction, r->length, r->after);
  }
}

/* The core's functions the link calls, wrapped by the linker (-Wl,--wrap): the servo's two
 * entry points for a packet (the wrapper sees the servo before the packet) and the finder's
 * gap poll (the reference finder is polled with it); each then calls the core's own. */
void __real_dxl_servo_prepare(const dxl_servo_t *servo, const dxl_packet_t *packet, dxl_response_t *response);
void __real_dxl_servo_reject_checksum(dxl_servo_t *servo, const dxl_packet_t *packet, dxl_response_t *response);
bool __real_dxl_finder_poll(dxl_finder_t *finder, uint16_t now_ms);
void __wrap_dxl_servo_prepare(const dxl_servo_t *servo, const dxl_packet_t *packet, dxl_response_t *response);
void __wrap_dxl_servo_reject_checksum(dxl_servo_t *servo, const dxl_packet_t *packet, dxl_response_t *response);
bool __wrap_dxl_finder_poll(dxl_finder_t *finder, uint16_t now_ms);

void __wrap_dxl_servo_prepare(const dxl_servo_t *servo, const dxl_packet_t *packet, dxl_response_t *response) {
  world_t *w = &world;
  packet_begins(w, servo);
  __real_dxl_servo_prepare(servo, packet, response);
  if (w->sniff == SNIFF_ARMED && w->uart.reply_state == DXL_LINK_REPLY_ARMED) {
    check_armed_prepare(w, packet, response);
  }
}

void __wrap_dxl_servo_reject_checksum(dxl_servo_t *servo, const dxl_packet_t *packet, dxl_response_t *response) {
  packet_begins(&world, servo);
  __real_dxl_servo_reject_checksum(servo, packet, response);
}

bool __wrap_dxl_finder_poll(dxl_finder_t *finder, uint16_t now_ms) {
  ref_finder_poll(&world.ref, now_ms);
  return __real_dxl_finder_poll(finder, now_ms);
}

/* The reply the UART sends (or not) is the servo's. */
static void check_reply_on_wire(const world_t *w, const dxl_response_t *r, bool replied, const char *what) {
  if (replied != (r->length != 0)) {
    fail("%s: %s", what, replied ? "a reply on the wire, none prepared" : "a reply prepared, none on the wire");
  }
  if (replied && (w->uart.reply_length != r->length || memcmp(w->uart.reply_bytes, r->bytes, r->length) != 0 ||
                  w->uart.reply_delay_us != r->delay_us)) {
    fail("%s: the reply on the wire (%u bytes, %u us) is not the prepared one (%u bytes, %u us)", what,
         w->uart.reply_length, w->uart.reply_delay_us, r->length, r->delay_us);
  }
}

/* A bad checksum (dxl_link.c on_bad_checksum), checked at once: nothing follows its reply. */
static void check_bad_checksum(world_t *w, const before_t *b, const dxl_packet_t *p, const dxl_response_t *r,
                               bool replied) {
  const dxl_servo_t *before = &b->servo;
  const uint8_t old_id = before->table[CT_ADDR_ID];
  const bool own = p->id == old_id;
  const bool due = own && before->table[CT_ADDR_STATUS_RETURN_LEVEL] >= 2;
  if (due != (r->length != 0)) {
    fail("bad checksum to ID %u (servo ID %u, level %u): %s", p->id, old_id,
         before->table[CT_ADDR_STATUS_RETURN_LEVEL], r->length != 0 ? "answered" : "not answered");
  }
  check_reply_on_wire(w, r, replied, "checksum error reply");
  if (r->length != 0) {
    check_status_packet(r, old_id, "checksum error reply");
    const uint8_t error = r->bytes[DXL_STATUS_ERROR_OFFSET];
    if ((error & DXL_ERR_EVENTS) != DXL_ERR_CHECKSUM || r->length != 6 ||
        ((error & DXL_ERR_ANGLE_LIMIT) != 0) != angle_condition(w, before->table)) {
      fail("checksum error reply: error 0x%02X, %u bytes", error, r->length);
    }
  }
  if (!servo_equal(before, &w->servo, false, false) || w->persists != b->persists || w->baud_sets != b->baud_sets ||
      r->after != 0 || r->action != DXL_ACTION_NONE) {
    fail("a bad checksum (ID %u) changed something", p->id);
  }
  const uint8_t pending = own ? (uint8_t)(before->pending_events | DXL_ERR_CHECKSUM) : before->pending_events;
  if (w->servo.pending_events != pending) {
    fail("a bad checksum (ID %u): pending events 0x%02X", p->id, w->servo.pending_events);
  }
}

/* The armed packet, complete: the one the sniff armed; what the link committed (prepared from
 * the candidate) is what the complete packet gives, and so is the ready reply a PING gets. */
static void check_armed_packet(const world_t *w, const dxl_packet_t *p, const dxl_response_t *committed,
                               dxl_response_t *complete) {
  if (!same_packet(p, w->sniffed)) {
    fail("the sniff's packet is not the finder's");
  }
  __real_dxl_servo_prepare(&w->handled.before.servo, p, complete);
  const dxl_response_t *r = complete;
  const dxl_response_t *early = committed;
  const bool streamed = p->instruction != DXL_INST_PING || p->param_count != 0;
  if (streamed &&
      (early->length != r->length || memcmp(early->bytes, r->bytes, r->length) != 0 ||
       early->delay_us != r->delay_us || early->after != r->after || early->action != r->action ||
       early->window_start != r->window_start || early->window_len != r->window_len || early->events != r->events ||
       (r->window_data != NULL && r->action != DXL_ACTION_NONE &&
        memcmp(early->window_data, r->window_data, r->window_len) != 0))) {
    fail("the response prepared before the checksum differs from the complete packet's");
  }
}

/* dxl_link_port_handled: a packet the link has handled (its reply started, if any). */
static void on_handled(void *context, dxl_find_result_t found, const uint8_t *bytes, uint16_t length,
                       const dxl_response_t *response) {
  world_t *w = context;
  handled_t *h = &w->handled;
  const bool armed = w->sniff == SNIFF_MATCHED && found == DXL_FIND_PACKET;
  if (!w->before.valid) {
    /* Only a PING answered with the ready reply is handled without the servo: nothing to
     * prepare nor commit. */
    if (!armed || length != 6u || bytes[4] != DXL_INST_PING) {
      fail("a packet (ID %u) handled without being handed to the servo", length > 2u ? bytes[2] : 0u);
    }
    packet_begins(w, &w->servo);
  }
  w->before.valid = false;
  w->sniff = SNIFF_IDLE;
  h->before = w->before;
  frame(bytes, length, &h->framed);
  const dxl_packet_t *p = &h->framed.packet;
  compare_with_reference(w, found, p);
  const bool replied = w->uart.reply_state == DXL_LINK_REPLY_SENDING;
  if (found == DXL_FIND_BAD_CHECKSUM) {
    check_bad_checksum(w, &h->before, p, response, replied);
    return;
  }
  const dxl_servo_t *before = &h->before.servo;
  dxl_response_t *r = &h->response;
  if (armed) {
    check_armed_packet(w, p, response, r);
  } else {
    memcpy(r, response, sizeof *r);
  }
  char what[96];
  snprintf(what, sizeof what, "packet ID %u instruction 0x%02X with %u parameters", p->id, p->instruction,
           p->param_count);
  check_reply_on_wire(w, r, replied, what);
  if (r->events == 0 && (p->id == before->table[CT_ADDR_ID] || p->id == DXL_ID_BROADCAST)) {
    unsigned start = 0;
    const unsigned len = written_window(before, p, &start);
    update_wheel_goal(w, before->table, w->servo.table, start, len);
  }
  /* The reply's Angle Limit bit: the condition as the packet leaves the table (before what
   * follows the reply, RESET's defaults). */
  if (r->length >= 6 && ((r->bytes[DXL_STATUS_ERROR_OFFSET] & DXL_ERR_ANGLE_LIMIT) != 0) !=
                            angle_condition(w, w->servo.table)) {
    fail("%s: reply error 0x%02X, but the Angle Limit condition is %s", what, r->bytes[DXL_STATUS_ERROR_OFFSET],
         angle_condition(w, w->servo.table) ? "on" : "off");
  }
  h->replied = replied;
  h->ticked = false;
  h->open = true;
}

/* ---------------------------------------------------------------------------------------
 * The main loop around the link (firmware/app/main.c)
 * --------------------------------------------------------------------------------------- */

static void millisecond(world_t *w);

/* The link's millisecond tick (the reference finder is polled when it polls its finder). */
static void link_tick(world_t *w) { dxl_link_tick(&w->link, &w->servo, now_ms(w)); }

/* The reply the link started is on the wire for reply_ms, the main loop's ticks and the
 * EEPROM writer running meanwhile; then its last stop bit has left. */
static void send_reply(world_t *w) {
  for (unsigned ms = 1; ms <= w->reply_ms; ms++) {
    millisecond(w);
    if (ms % EEPROM_WRITE_EVERY_MS == 0) {
      (void)service_store(w, NULL);
    }
  }
  fake_uart_reply_sent(&w->uart);
}

/* Main-loop passes until the link has nothing left to do: each reply it starts is sent, and
 * what follows it has run. Then the ring is empty, the reference finder has nothing to report
 * either, and the last packet is complete. */
static void run(world_t *w) {
  for (unsigned pass = 0;; pass++) {
    if (pass == MAX_PASSES) {
      fail("the link still asks for passes after %u", MAX_PASSES);
    }
    w->uart.woken = false;
    w->uart.log[0] = '\0'; /* the fake's event log is not read here */
    const bool reply_sent = w->uart.reply_state == DXL_LINK_REPLY_DONE;
    dxl_link_service_reply(&w->link, &w->servo);
    if (reply_sent) {
      if (w->uart.reply_state != DXL_LINK_REPLY_IDLE) {
        fail("the link left a sent reply in state %u", w->uart.reply_state);
      }
      finish_handled(w);
    }
    dxl_link_service_rx(&w->link, &w->servo);
    if (w->uart.reply_state == DXL_LINK_REPLY_SENDING) {
      send_reply(w);
    } else if (!w->uart.woken) {
      break;
    }
  }
  if (w->uart.reply_state != DXL_LINK_REPLY_ARMED && w->uart.head != w->uart.tail) {
    fail("%u bytes left in the ring with the link idle", (uint8_t)(w->uart.head - w->uart.tail));
  }
  compare_with_reference(w, DXL_FIND_NONE, NULL);
  if (w->handled.open && w->handled.replied) {
    fail("the link is idle with a reply not sent");
  }
  finish_handled(w);
}

/* Bytes arrive at the UART: as many as the ring holds before the link's next passes (one
 * batch for the finder), the rest after them. */
static void receive(world_t *w, const uint8_t *bytes, size_t count) {
  size_t done = 0;
  do {
    const size_t room = RING_CAPACITY - (uint8_t)(w->uart.head - w->uart.tail);
    const size_t n = count - done < room ? count - done : room;
    for (size_t i = 0; i < n; i++) {
      (void)fake_uart_receive(&w->uart, bytes[done + i]);
    }
    done += n;
    run(w);
  } while (done < count);
}


/* One control tick. Only the Present items and Moving may change, and Torque Enable (and in
 * profile ax12a Torque Limit) only to 0: every other address is compared, so the ranges hold
 * after a tick because they held before it (check_ranges would cost the fuzzer most of its
 * time here: ticks come by the thousand). Not instrumented for coverage: its checks guide no
 * search (the core's tick, compiled apart, still is), and their comparisons were a third of
 * the fuzzer's time; ASan and UBSan still check it. */
__attribute__((no_sanitize("coverage"))) static void control_tick(world_t *w) {
  uint8_t before[CT_SIZE];
  memcpy(before, w->servo.table, CT_SIZE);
  const uint8_t reg_len = w->servo.reg_len;
  const bool goal_flag = w->servo.goal_written_in_wheel_mode;
  const uint8_t pending = w->servo.pending_events;
  if (w->handled.open) {
    w->handled.ticked = true;
  }
  bool led;
  const int16_t drive = dxl_control_tick(&w->control, &w->servo, &w->sensors, &led);
  if (drive < -DXL_DRIVE_MAX || drive > DXL_DRIVE_MAX) {
    fail("control tick: drive %d", drive);
  }
  const uint8_t *t = w->servo.table;
  /* docs/policy.md "Alarms": the voltage and temperature conditions from the limits; Alarm
   * Shutdown turns torque off when an alarm it selects holds (a condition, or an event since
   * the last tick), and nothing else does. */
  const dxl_sensors_t *in = &w->sensors;
  const bool voltage = in->voltage_dv < t[CT_ADDR_LOWEST_LIMIT_VOLTAGE] || in->voltage_dv > t[CT_ADDR_HIGHEST_LIMIT_VOLTAGE];
  const bool heat = in->temperature_c > t[CT_ADDR_HIGHEST_LIMIT_TEMP];
  const uint8_t conditions = dxl_servo_conditions(&w->servo);
  if (((conditions & DXL_ERR_VOLTAGE) != 0) != voltage || ((conditions & DXL_ERR_OVERHEATING) != 0) != heat) {
    fail("control tick: conditions 0x%02X at %u dV (limits %u..%u), %u degC (limit %u)", conditions, in->voltage_dv,
         t[CT_ADDR_LOWEST_LIMIT_VOLTAGE], t[CT_ADDR_HIGHEST_LIMIT_VOLTAGE], in->temperature_c,
         t[CT_ADDR_HIGHEST_LIMIT_TEMP]);
  }
  const bool shut_down = before[CT_ADDR_TORQUE_ENABLE] != 0 && ((conditions | pending) & t[CT_ADDR_ALARM_SHUTDOWN]) != 0;
  if ((before[CT_ADDR_TORQUE_ENABLE] != 0 && t[CT_ADDR_TORQUE_ENABLE] == 0) != shut_down) {
    fail("control tick: Torque Enable %u -> %u with alarms 0x%02X, Alarm Shutdown 0x%02X", before[CT_ADDR_TORQUE_ENABLE],
         t[CT_ADDR_TORQUE_ENABLE], conditions | pending, t[CT_ADDR_ALARM_SHUTDOWN]);
  }
  if (t[CT_ADDR_TORQUE_ENABLE] == 0 && drive != 0) {
    fail("control tick: drive %d with torque off", drive);
  }
  if (DXL_PROFILE == DXL_PROFILE_AX12A && shut_down && ct_get_u16(t, CT_ADDR_TORQUE_LIMIT) != 0) {
    fail("control tick: shut down (profile ax12a) with Torque Limit %u", ct_get_u16(t, CT_ADDR_TORQUE_LIMIT));
  }
  for (uint8_t a = 0; a < CT_PRESENT_FIRST; a++) {
    if (t[a] != before[a]) {
      const bool shutdown = (a == CT_ADDR_TORQUE_ENABLE || (DXL_PROFILE == DXL_PROFILE_AX12A &&
                                                            (a == CT_ADDR_TORQUE_LIMIT || a == CT_ADDR_TORQUE_LIMIT + 1))) &&
                            t[a] == 0;
      if (!shutdown) {
        fail("control tick changed address %u: %u -> %u", a, before[a], t[a]);
      }
    }
  }
  if (memcmp(&t[CT_ADDR_REGISTERED_INSTRUCTION], &before[CT_ADDR_REGISTERED_INSTRUCTION], 2) != 0 ||
      memcmp(&t[CT_ADDR_LOCK], &before[CT_ADDR_LOCK], CT_SIZE - CT_ADDR_LOCK) != 0 || t[CT_ADDR_MOVING] > 1) {
    fail("control tick changed an address above the Present items other than Moving, or Moving reads %u",
         t[CT_ADDR_MOVING]);
  }
  if (w->servo.pending_events != 0 || reg_len != w->servo.reg_len || goal_flag != w->servo.goal_written_in_wheel_mode) {
    fail("control tick: events left pending, or the REG_WRITE slot or wheel goal flag changed");
  }
}

/* One millisecond of the main loop's tick (main.c service_tick): the link's timeouts and gap
 * poll, the control tick, then the link told the conditions (for its ready PING reply). */
static void millisecond(world_t *w) {
  pass_ms(w, 1);
  link_tick(w);
  control_tick(w);
  dxl_link_conditions_changed(&w->link, &w->servo, w->control.conditions);
}

/* ---------------------------------------------------------------------------------------
 * Power
 * --------------------------------------------------------------------------------------- */

static void power_up(world_t *w) {
  const uint8_t *stored = eeprom_model_boot(&w->eeprom);
  if (stored == NULL) {
    if (w->have_stored) {
      fail("power-up found no valid settings, but settings were stored");
    }
  } else {
    const bool is_stored = w->have_stored && memcmp(stored, w->stored, CT_EEPROM_SIZE) == 0;
    const bool is_prior = w->have_prior && memcmp(stored, w->prior, CT_EEPROM_SIZE) == 0;
    if (!is_stored && !is_prior) {
      fail("power-up found settings other than the last stored (ID %u, baud %u)", stored[CT_ADDR_ID],
           stored[CT_ADDR_BAUD_RATE]);
    }
    memcpy(w->stored, stored, CT_EEPROM_SIZE);
  }
  w->have_stored = stored != NULL;
  w->have_prior = false;
  w->have_under_way = false;
  w->have_latest = false;
  dxl_servo_power_up(&w->servo, stored, w->sensors.position_counts);
  w->wheel_goal_written = false;
  if (stored == NULL) {
    store_settings(w, w->servo.table); /* main.c: factory defaults, written back */
  }
  const uint64_t now_us = w->uart.now_us;
  fake_uart_init(&w->uart, w->servo.table[CT_ADDR_BAUD_RATE]);
  w->uart.now_us = now_us;
  w->uart.on_take = on_take;
  w->uart.on_store = on_store;
  w->uart.on_baud = on_baud;
  w->uart.on_handled = on_handled;
  w->uart.context = w;
  ref_finder_init(&w->ref);
  dxl_control_init(&w->control);
  w->before.valid = false;
  w->handled.open = false;
  w->sniff = SNIFF_IDLE;
  dxl_link_init(&w->link, &w->servo, &w->uart);
  check_ranges(w->servo.table, "after power-up");
  check_angle_condition(w, "after power-up");
  check_eeprom_idle(w, "after power-up");
}

/* A stored area from the input: raw values, so out-of-range ones occur. */
static void take_area(input_t *in, uint8_t area[CT_EEPROM_SIZE]) {
  dxl_servo_t factory;
  dxl_servo_power_up(&factory, NULL, 0);
  memcpy(area, factory.table, CT_EEPROM_SIZE);
  area[CT_ADDR_ID] = take(in);
  area[CT_ADDR_BAUD_RATE] = take(in);
  area[CT_ADDR_RETURN_DELAY_TIME] = take(in);
  area[CT_ADDR_STATUS_RETURN_LEVEL] = take(in);
  ct_set_u16(area, CT_ADDR_CW_ANGLE_LIMIT, take16(in));
  ct_set_u16(area, CT_ADDR_CCW_ANGLE_LIMIT, take16(in));
  ct_set_u16(area, CT_ADDR_MAX_TORQUE, take16(in));
  area[CT_ADDR_ALARM_LED] = take(in);
  area[CT_ADDR_ALARM_SHUTDOWN] = take(in);
}

static void start(world_t *w, input_t *in) {
  uint8_t *image = w->eeprom.image;
  memset(image, 0xFF, DXL_IMAGE_BYTES);
  uint8_t a[CT_EEPROM_SIZE];
  uint8_t b[CT_EEPROM_SIZE];
  switch (take(in) % FUZZ_START_COUNT) {
  case FUZZ_START_BLANK:
    break;
  case FUZZ_START_ONE_SLOT:
    take_area(in, a);
    dxl_image_build(image, a);
    break;
  case FUZZ_START_TWO_SLOTS: {
    take_area(in, a);
    take_area(in, b);
    const uint8_t sequence = take(in);
    dxl_image_slot_build(image, a, sequence);
    dxl_image_slot_build(&image[dxl_image_slot_offset(1)], b, (uint8_t)(sequence + take(in)));
    break;
  }
  default: { /* FUZZ_START_TORN_SLOT: what a store cut before this power-up leaves */
    take_area(in, a);
    take_area(in, b);
    const uint8_t sequence = take(in);
    const unsigned writes = take(in) % (DXL_IMAGE_SLOT_BYTES + 1u);
    const uint8_t torn = take(in);
    dxl_servo_t factory;
    dxl_servo_power_up(&factory, NULL, 0);
    eeprom_model_t before_cut;
    memset(before_cut.image, 0xFF, DXL_IMAGE_BYTES);
    dxl_image_slot_build(before_cut.image, factory.table, (uint8_t)(sequence - 1u));
    dxl_image_slot_build(&before_cut.image[dxl_image_slot_offset(1)], a, sequence);
    (void)eeprom_model_boot(&before_cut);
    eeprom_model_persist(&before_cut, b);
    for (unsigned i = 0; i < writes; i++) {
      (void)eeprom_model_service(&before_cut, NULL);
    }
    (void)eeprom_model_service(&before_cut, &torn);
    memcpy(image, before_cut.image, DXL_IMAGE_BYTES);
    break;
  }
  }
  /* What the EEPROM holds before the first power-up counts as stored. */
  const uint8_t *settings = dxl_image_settings(image);
  w->have_stored = settings != NULL;
  if (settings != NULL) {
    memcpy(w->stored, settings, CT_EEPROM_SIZE);
  }
  w->sensors.position_counts = (uint16_t)(take16(in) & PRESENT_POSITION_MAX);
  w->sensors.voltage_dv = 96;
  w->sensors.temperature_c = 25;
  power_up(w);
}

/* ---------------------------------------------------------------------------------------
 * Operations
 * --------------------------------------------------------------------------------------- */

/* Whether the RX interrupt's sniff arms this packet's reply once it runs (firmware/hal/uart_rx.S,
 * docs/firmware.md "Receive"): this servo's ID, an instruction of dxl_servo_stream_mask(), a
 * WRITE from past the EEPROM area's ID and Baud Rate, LENGTH up to SNIFF_MAX_LENGTH. */
static bool sniff_would_arm(const world_t *w, const dxl_packet_t *p) {
  if (p->id != w->servo.table[CT_ADDR_ID] || p->instruction >= 8u || p->param_count + 2u > SNIFF_MAX_LENGTH) {
    return false;
  }
  if ((dxl_servo_stream_mask(&w->servo) & (1u << p->instruction)) == 0) {
    return false;
  }
  return !(p->instruction == DXL_INST_WRITE && p->param_count >= 1 && p->params[0] < DXL_STREAM_WRITE_MIN_ADDR);
}

/* The RX interrupt's sniff for a packet it arms (fake_uart.h: the caller plays it). The link,
 * idle, starts the sniff (else the finder holds bytes, the sniff does not run, and the packet
 * arrives as a batch); the sniff holds the bytes up to the checksum in the ring and arms the
 * reply at the last of them; the link takes the packet over, prepares the reply and publishes
 * it. The checksum comes late_ms later, the link's millisecond ticks and passes running
 * meanwhile (a link gives the armed reply up after DXL_LINK_SNIFF_MAX_MS without a byte), and
 * starts the reply if it matches and the reply is still armed. */
static void deliver_armed(world_t *w, const uint8_t *bytes, size_t count, const dxl_packet_t *sent, bool matches,
                          unsigned late_ms) {
  w->uart.sniff_enabled = true;
  run(w);
  w->uart.sniff_enabled = false; /* played for this packet only */
  if (w->uart.sniff != DXL_LINK_SNIFF_WAITING) {
    receive(w, bytes, count);
    return;
  }
  for (size_t i = 0; i + 1u < count; i++) {
    (void)fake_uart_receive(&w->uart, bytes[i]);
  }
  w->sniff = SNIFF_ARMED;
  w->sniffed = sent;
  w->before.valid = false;
  fake_uart_arm(&w->uart, sent->instruction == DXL_INST_PING && sent->param_count == 0);
  run(w);
  if (w->uart.reply_state == DXL_LINK_REPLY_ARMED && fake_uart_reply_ready(&w->uart) != w->uart.reply_length) {
    fail("the armed reply is not published before the checksum (%u of %u bytes)", fake_uart_reply_ready(&w->uart),
         w->uart.reply_length);
  }
  for (unsigned ms = 0; ms < late_ms; ms++) {
    pass_ms(w, 1);
    link_tick(w);
    run(w);
  }
  w->sniff = matches && w->uart.reply_state == DXL_LINK_REPLY_ARMED ? SNIFF_MATCHED : SNIFF_IDLE;
  fake_uart_checksum(&w->uart, bytes[count - 1u], matches);
  run(w);
  w->sniff = SNIFF_IDLE;
}

static void op_packet(world_t *w, input_t *in) {
  const uint8_t sel = take(in);
  const uint8_t mode = take(in);
  const uint8_t own = w->servo.table[CT_ADDR_ID];
  uint8_t id;
  switch (sel & 3u) {
  case FUZZ_ID_OWN:
    id = own;
    break;
  case FUZZ_ID_BROADCAST:
    id = DXL_ID_BROADCAST;
    break;
  case FUZZ_ID_GIVEN:
    id = take(in);
    break;
  default:
    id = (uint8_t)(own + 1u);
    break;
  }
  static const uint8_t instructions[] = {DXL_INST_PING,   DXL_INST_READ,  DXL_INST_WRITE,      DXL_INST_REG_WRITE,
                                         DXL_INST_ACTION, DXL_INST_RESET, DXL_INST_SYNC_WRITE, 0};
  const unsigned inst_sel = (sel >> 2) & 7u;
  const uint8_t instruction = inst_sel == FUZZ_INST_GIVEN ? take(in) : instructions[inst_sel];
  uint8_t params[256];
  unsigned n = 0;
  if (sel & FUZZ_SEL_RAW_PARAMS) {
    n = take(in);
    if (n > 253u) {
      n = 253u; /* LENGTH <= 255 */
    }
    for (unsigned i = 0; i < n; i++) {
      params[i] = take(in);
    }
  } else {
    switch (instruction) {
    case DXL_INST_READ:
      params[n++] = take(in);
      params[n++] = take(in);
      break;
    case DXL_INST_WRITE:
    case DXL_INST_REG_WRITE: {
      params[n++] = (uint8_t)(take(in) % CT_SIZE);
      const unsigned l = take(in) % FUZZ_WRITE_L_MOD + 1u;
      for (unsigned i = 0; i < l; i++) {
        params[n++] = take(in);
      }
      break;
    }
    case DXL_INST_SYNC_WRITE: {
      params[n++] = (uint8_t)(take(in) % CT_SIZE);
      const unsigned l = take(in) % FUZZ_SYNC_L_MOD + 1u;
      params[n++] = (uint8_t)l;
      const unsigned slices = take(in) % FUZZ_SYNC_N_MOD;
      for (unsigned s = 0; s < slices; s++) {
        params[n++] = (take(in) & 1u) ? own : take(in);
        for (unsigned i = 0; i < l; i++) {
          params[n++] = take(in);
        }
      }
      break;
    }
    default:
      break;
    }
  }
  uint8_t bytes[3 + 2 + 256 + 2];
  size_t count = 0;
  for (unsigned i = 0; i < 2u + ((mode >> 3) & 3u); i++) {
    bytes[count++] = DXL_HEADER_BYTE;
  }
  const size_t id_at = count;
  bytes[count++] = id;
  bytes[count++] = (uint8_t)(n + 2u);
  bytes[count++] = instruction;
  memcpy(&bytes[count], params, n);
  count += n;
  uint8_t checksum = dxl_checksum(&bytes[id_at], (uint16_t)(count - id_at));
  if (mode & FUZZ_MODE_BAD_CHECKSUM) {
    checksum ^= (uint8_t)(take(in) | 1u);
  }
  bytes[count++] = checksum;

  w->reply_ms = (mode & FUZZ_MODE_REPLY_TIME) ? take(in) : 0u;
  switch (mode & 3u) {
  case FUZZ_DELIVER_BYTES:
    for (size_t i = 0; i < count; i++) {
      receive(w, &bytes[i], 1);
    }
    break;
  case FUZZ_DELIVER_BATCH:
    receive(w, bytes, count);
    break;
  case FUZZ_DELIVER_SPLIT: {
    const uint8_t wait = take(in);
    const size_t split = take(in) % (count + 1u);
    receive(w, bytes, split);
    pass_ms(w, wait); /* the rest taken in the pass that first sees the time passed */
    receive(w, bytes + split, count - split);
    link_tick(w);
    run(w);
    break;
  }
  default: { /* FUZZ_DELIVER_EARLY */
    const unsigned late_ms = (mode & FUZZ_MODE_LATE_CHECKSUM) ? take(in) : 0u;
    const dxl_packet_t sent = {id, instruction, (uint8_t)n, params, checksum};
    if (sniff_would_arm(w, &sent)) {
      deliver_armed(w, bytes, count, &sent, (mode & FUZZ_MODE_BAD_CHECKSUM) == 0, late_ms);
    } else {
      receive(w, bytes, count);
    }
    break;
  }
  }
  w->reply_ms = 0;
}

static void op_ticks(world_t *w, input_t *in) {
  unsigned n = take(in);
  const uint8_t flags = take(in);
  if (flags & 1u) {
    n *= FUZZ_TICKS_MANY;
  }
  int position = take16(in) & PRESENT_POSITION_MAX;
  const int step = (int8_t)take(in);
  w->sensors.voltage_dv = take(in);
  w->sensors.temperature_c = take(in);
  for (unsigned i = 0; i < n; i++) {
    position += step;
    position = position < 0 ? 0 : position > (int)PRESENT_POSITION_MAX ? (int)PRESENT_POSITION_MAX : position;
    w->sensors.position_counts = (uint16_t)position;
    millisecond(w);
    /* Passes when the tick's gap poll gave the finder bytes to rescan: otherwise the link is
     * idle (the ring empty, no reply under way), a pass changes nothing, and ticks come by
     * the thousand. */
    if (w->link.finder_dirty) {
      run(w);
    }
  }
  run(w);
}

static void op_cut(world_t *w, input_t *in) {
  const uint8_t how = take(in);
  const uint8_t garbage = take(in);
  w->sensors.position_counts = (uint16_t)(take16(in) & PRESENT_POSITION_MAX);
  if ((how & 1u) && eeprom_model_busy(&w->eeprom)) {
    (void)service_store(w, &garbage); /* the byte being written is torn */
  }
  power_up(w);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  world_t *w = &world;
  memset(w, 0, sizeof *w);
  input_t in = {data, size};
  op_index = 0;
  start(w, &in);
  while (in.left != 0 && op_index < MAX_OPS) {
    op_index++;
    switch (take(&in) % FUZZ_OP_COUNT) {
    case FUZZ_OP_PUSH_BYTE: {
      const uint8_t byte = take(&in);
      receive(w, &byte, 1);
      break;
    }
    case FUZZ_OP_PUSH_BATCH: {
      uint8_t bytes[256];
      const unsigned n = take(&in);
      for (unsigned i = 0; i < n; i++) {
        bytes[i] = take(&in);
      }
      receive(w, bytes, n);
      break;
    }
    case FUZZ_OP_WAIT:
      pass_ms(w, take(&in));
      link_tick(w);
      run(w);
      break;
    case FUZZ_OP_WAIT_LONG:
      pass_ms(w, take16(&in));
      link_tick(w);
      run(w);
      break;
    case FUZZ_OP_TICKS:
      op_ticks(w, &in);
      break;
    case FUZZ_OP_PACKET:
      op_packet(w, &in);
      break;
    case FUZZ_OP_EEPROM: {
      const unsigned n = take(&in) + 1u;
      for (unsigned i = 0; i < n; i++) {
        (void)service_store(w, NULL);
      }
      check_eeprom_idle(w, "after EEPROM writes");
      break;
    }
    case FUZZ_OP_EEPROM_FLUSH:
      flush_store(w);
      check_eeprom_idle(w, "after the store");
      break;
    case FUZZ_OP_CUT:
      op_cut(w, &in);
      break;
    default: /* FUZZ_OP_PASS */
      run(w);
      break;
    }
  }
  /* The end: the store runs out, then a power cycle finds exactly the settings in use. */
  flush_store(w);
  check_eeprom_idle(w, "at the end");
  uint8_t in_use[CT_EEPROM_SIZE];
  memcpy(in_use, w->servo.table, CT_EEPROM_SIZE);
  power_up(w);
  if (memcmp(in_use, w->servo.table, CT_EEPROM_SIZE) != 0) {
    fail("a power cycle after the store does not bring back the settings in use");
  }
  return 0;
}
