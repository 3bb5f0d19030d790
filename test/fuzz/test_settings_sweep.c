/* The settings sweep (issue #15), deterministic beside the fuzzer because value-specific bugs
 * hide from it: every WRITE window (start, length) that starts in the EEPROM area
 * (addresses 0..23, any length up to address 49) x value patterns (each item at its minimum,
 * maximum, one above, one below, and bytes 0x00, 0xFF, 0x55/0xAA alternating both ways) x
 * starting states (what the EEPROM holds, Lock off and on), plus RESET from each state; each
 * write goes through the core and the link layer as the firmware runs them
 * (dxl_servo_handle, dxl_after_commit, dxl_after_reply) into the EEPROM writer of nvm.c
 * (test/support/eeprom_model.h). Then:
 *   - a refused write (Range Error) changes nothing and stores nothing; while locked every
 *     write here is refused (docs/policy.md "Lock");
 *   - an accepted one stores the table's EEPROM area once, every item inside its range;
 *   - its store is cut after every byte it writes and in the middle of every byte's write
 *     (the byte left at 0x00, 0xFF, 0x5A, and at its old value with one bit flipped), and the
 *     servo powered up again: what it reads is exactly the settings before the write or the
 *     new ones, the new ones once the store has run to its end, and the power-up makes of them
 *     what docs/policy.md "Power-up" says (out-of-range items repaired). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "dxl_after.h"
#include "dxl_after_port.h"
#include "dxl_image.h"
#include "dxl_protocol.h"
#include "dxl_servo.h"
#include "dxl_table.h"
#include "item_ranges.h"
#include "eeprom_model.h"

#define PRESENT_POSITION 512u

/* The port: stores go to the model; every persist is counted. */
typedef struct {
  eeprom_model_t eeprom;
  unsigned persists;
} port_t;

void dxl_after_port_persist(void *port, const uint8_t *table) {
  port_t *p = port;
  eeprom_model_persist(&p->eeprom, table);
  p->persists++;
}

void dxl_after_port_set_baud(void *port, uint8_t baud_register) {
  (void)port;
  (void)baud_register;
}

/* ---- ct_items.h read directly: ranges and patterns ---- */

/* items[], ITEM_COUNT: item_ranges.h */

static const item_t *item_at(uint8_t addr) {
  for (size_t i = 0; i < ITEM_COUNT; i++) {
    if (addr >= items[i].addr && addr < items[i].addr + items[i].size) {
      return &items[i];
    }
  }
  return NULL;
}

typedef enum { PAT_MIN, PAT_MAX, PAT_ABOVE, PAT_BELOW, PAT_00, PAT_FF, PAT_55AA, PAT_AA55, PAT_COUNT } pattern_t;
static const char *const pattern_names[PAT_COUNT] = {"min", "max", "max+1", "min-1", "0x00", "0xFF", "55AA", "AA55"};

/* The byte pattern p puts at address addr. */
static uint8_t pattern_byte(pattern_t p, uint8_t addr) {
  const item_t *item = item_at(addr);
  uint16_t value;
  switch (p) {
  case PAT_MIN:
    value = item->min;
    break;
  case PAT_MAX:
    value = item->max;
    break;
  case PAT_ABOVE:
    value = (uint16_t)(item->max + 1u);
    break;
  case PAT_BELOW:
    value = (uint16_t)(item->min - 1u);
    break;
  case PAT_00:
    return 0x00;
  case PAT_FF:
    return 0xFF;
  case PAT_55AA:
    return (addr & 1u) ? 0xAA : 0x55;
  default:
    return (addr & 1u) ? 0x55 : 0xAA;
  }
  if (item->size == 1) {
    return (uint8_t)value;
  }
  return addr == item->addr ? (uint8_t)(value & 0xFFu) : (uint8_t)(value >> 8);
}

static void assert_eeprom_items_in_range(const uint8_t *table, const char *context) {
  for (size_t i = 0; i < ITEM_COUNT; i++) {
    const item_t *item = &items[i];
    if (item->addr >= CT_EEPROM_SIZE || item->access != CT_RW) {
      continue;
    }
    const uint16_t value = item->size == 2 ? ct_get_u16(table, item->addr) : table[item->addr];
    if (value < item->min || value > item->max) {
      fail_msg("%s: %s holds %u, outside %u..%u", context, item->name, value, item->min, item->max);
    }
  }
}

/* ---- starting states ---- */

typedef struct {
  const char *name;
  uint8_t image[DXL_IMAGE_BYTES];
} state_t;

static void factory_area(uint8_t area[CT_EEPROM_SIZE]) {
  dxl_servo_t servo;
  dxl_servo_power_up(&servo, NULL, PRESENT_POSITION);
  memcpy(area, servo.table, CT_EEPROM_SIZE);
}

#define STATE_COUNT 4
static state_t states[STATE_COUNT];

static void build_states(void) {
  uint8_t area[CT_EEPROM_SIZE];
  uint8_t other[CT_EEPROM_SIZE];

  states[0].name = "factory settings in both slots (dxl_image_build: a new servo)";
  factory_area(area);
  dxl_image_build(states[0].image, area);

  states[1].name = "slot 1 newest at sequence 255 (ID 200, wheel mode, level 1), slot 0 at 254";
  factory_area(other);
  other[CT_ADDR_ID] = 17;
  factory_area(area);
  area[CT_ADDR_ID] = 200;
  area[CT_ADDR_BAUD_RATE] = 34;
  area[CT_ADDR_RETURN_DELAY_TIME] = 0;
  ct_set_u16(area, CT_ADDR_CW_ANGLE_LIMIT, 0);
  ct_set_u16(area, CT_ADDR_CCW_ANGLE_LIMIT, 0);
  area[CT_ADDR_STATUS_RETURN_LEVEL] = 1;
  memset(states[1].image, 0xFF, DXL_IMAGE_BYTES);
  dxl_image_slot_build(states[1].image, other, 254);
  dxl_image_slot_build(&states[1].image[dxl_image_slot_offset(1)], area, 255);

  states[2].name = "slot 0 in use (narrow limits, Max Torque 341), slot 1 left torn by a cut";
  factory_area(area);
  ct_set_u16(area, CT_ADDR_CW_ANGLE_LIMIT, 300);
  ct_set_u16(area, CT_ADDR_CCW_ANGLE_LIMIT, 700);
  ct_set_u16(area, CT_ADDR_MAX_TORQUE, 341);
  area[CT_ADDR_RESERVED_19] = 1;
  memset(states[2].image, 0xFF, DXL_IMAGE_BYTES);
  dxl_image_slot_build(states[2].image, area, 7);
  factory_area(other);
  other[CT_ADDR_ID] = 99;
  dxl_image_slot_build(&states[2].image[dxl_image_slot_offset(1)], other, 8);
  states[2].image[dxl_image_slot_offset(1) + 12] ^= 0x40u; /* torn: its CRC fails */

  states[3].name = "stored items out of range (repaired at power-up)";
  factory_area(area);
  area[CT_ADDR_ID] = 254;
  area[CT_ADDR_BAUD_RATE] = 255;
  area[CT_ADDR_STATUS_RETURN_LEVEL] = 3;
  ct_set_u16(area, CT_ADDR_CW_ANGLE_LIMIT, 2000);
  area[CT_ADDR_LOWEST_LIMIT_VOLTAGE] = 10;
  area[CT_ADDR_ALARM_LED] = 0xFF;
  dxl_image_build(states[3].image, area);
}

/* ---- power-up and cuts ---- */

/* Powers a servo up from the model as main.c does; returns the raw settings read (copied to
 * raw_out) or false when there were none (factory defaults, stored at once). */
static bool power_up(port_t *port, dxl_servo_t *servo, uint8_t raw_out[CT_EEPROM_SIZE]) {
  const uint8_t *stored = eeprom_model_boot(&port->eeprom);
  if (stored != NULL) {
    memcpy(raw_out, stored, CT_EEPROM_SIZE);
  }
  dxl_servo_power_up(servo, stored, PRESENT_POSITION);
  if (stored == NULL) {
    dxl_after_port_persist(port, servo->table);
    (void)eeprom_model_flush(&port->eeprom);
  }
  return stored != NULL;
}

/* What a power-up makes of stored settings. */
static void repaired(const uint8_t *raw, uint8_t out[CT_SIZE]) {
  memset(out, 0, CT_SIZE);
  memcpy(out, raw, CT_EEPROM_SIZE);
  ct_repair_stored_eeprom(out);
}

typedef struct {
  unsigned long writes, refused, stores, cuts, booted_old, booted_new;
} stats_t;

static const uint8_t torn_values[] = {0x00, 0xFF, 0x5A};
#define TORN_VARIANTS (sizeof torn_values + 1u) /* + the old value with a bit flipped */

/* Cuts the store under way in `after` (its model state right after the commit) at every
 * point, and checks each power-up. old/new_area: the raw settings before and the new ones. */
static void cut_everywhere(const port_t *after, const uint8_t *old_area, const uint8_t *new_area, stats_t *stats,
                           const char *context) {
  port_t probe = *after;
  const unsigned total = eeprom_model_flush(&probe.eeprom);
  for (unsigned done = 0; done <= total; done++) {
    for (unsigned variant = 0; variant <= TORN_VARIANTS; variant++) {
      port_t cut = *after;
      for (unsigned i = 0; i < done; i++) {
        assert_true(eeprom_model_service(&cut.eeprom, NULL));
      }
      bool torn = false;
      if (variant < TORN_VARIANTS && done < total) {
        /* The next byte's write is cut: find it, then leave it at the torn value. */
        eeprom_model_t peek = cut.eeprom;
        uint8_t before_image[DXL_IMAGE_BYTES];
        memcpy(before_image, peek.image, DXL_IMAGE_BYTES);
        assert_true(eeprom_model_service(&peek, NULL));
        size_t at = 0;
        while (at < DXL_IMAGE_BYTES && before_image[at] == peek.image[at]) {
          at++;
        }
        assert_true(at < DXL_IMAGE_BYTES);
        const uint8_t value = variant < sizeof torn_values ? torn_values[variant] : (uint8_t)(before_image[at] ^ 0x10u);
        assert_true(eeprom_model_service(&cut.eeprom, &value));
        torn = true;
      } else if (variant != TORN_VARIANTS) {
        continue; /* nothing left to tear: only the clean cut */
      }
      dxl_servo_t servo;
      uint8_t raw[CT_EEPROM_SIZE];
      if (!power_up(&cut, &servo, raw)) {
        fail_msg("%s: a cut after %u of %u bytes%s boots no settings", context, done, total, torn ? " (torn)" : "");
      }
      const bool is_old = memcmp(raw, old_area, CT_EEPROM_SIZE) == 0;
      const bool is_new = memcmp(raw, new_area, CT_EEPROM_SIZE) == 0;
      if (!is_old && !is_new) {
        fail_msg("%s: a cut after %u of %u bytes%s boots settings never stored", context, done, total,
                 torn ? " (torn)" : "");
      }
      if (done == total && !torn && !is_new) {
        fail_msg("%s: the store ran to its end but the old settings boot", context);
      }
      uint8_t expected[CT_SIZE];
      repaired(raw, expected);
      assert_memory_equal(servo.table, expected, CT_EEPROM_SIZE);
      stats->cuts++;
      stats->booted_old += is_old && !is_new;
      stats->booted_new += is_new && !is_old;
    }
  }
}

/* The servo of a starting state, powered up, its first store (if any) complete. */
static void given_state(const state_t *state, bool locked, port_t *port, dxl_servo_t *servo,
                        uint8_t raw[CT_EEPROM_SIZE]) {
  memset(port, 0, sizeof *port);
  memcpy(port->eeprom.image, state->image, DXL_IMAGE_BYTES);
  assert_true(power_up(port, servo, raw));
  if (locked) {
    const uint8_t one = 1;
    const dxl_packet_t lock = {servo->table[CT_ADDR_ID], DXL_INST_WRITE, 2, (const uint8_t[]){CT_ADDR_LOCK, one}, 0};
    dxl_response_t response;
    dxl_servo_handle(servo, &lock, &response);
    assert_int_equal(response.events, 0);
    assert_int_equal(servo->table[CT_ADDR_LOCK], 1);
  }
  port->persists = 0;
}

static void sweep_state(const state_t *state, bool locked, stats_t *stats) {
  port_t base_port;
  dxl_servo_t base;
  uint8_t old_area[CT_EEPROM_SIZE];
  given_state(state, locked, &base_port, &base, old_area);
  for (uint8_t start = 0; start < CT_EEPROM_SIZE; start++) {
    for (uint8_t len = 1; start + len <= CT_SIZE; len++) {
      for (pattern_t pattern = 0; pattern < PAT_COUNT; pattern++) {
        char context[256];
        snprintf(context, sizeof context, "%s%s: WRITE %u..%u %s", state->name, locked ? ", locked" : "", start,
                 start + len - 1u, pattern_names[pattern]);
        port_t port = base_port;
        dxl_servo_t servo = base;
        uint8_t params[1 + CT_SIZE];
        params[0] = start;
        for (uint8_t i = 0; i < len; i++) {
          params[1u + i] = pattern_byte(pattern, (uint8_t)(start + i));
        }
        const dxl_packet_t packet = {servo.table[CT_ADDR_ID], DXL_INST_WRITE, (uint8_t)(len + 1u), params, 0};
        dxl_response_t response;
        dxl_servo_handle(&servo, &packet, &response);
        dxl_after_commit(&servo, response.after, &port);
        dxl_after_reply(&servo, response.after, &port);
        stats->writes++;
        if (response.events != 0) {
          stats->refused++;
          if (port.persists != 0 || memcmp(servo.table, base.table, CT_SIZE) != 0) {
            fail_msg("%s: refused (error 0x%02X) but changed or stored something", context, response.events);
          }
          continue;
        }
        if (locked) {
          fail_msg("%s: accepted while locked", context);
        }
        if (port.persists != 1) {
          fail_msg("%s: accepted, stored %u times", context, port.persists);
        }
        assert_memory_equal(&servo.table[start], &params[1], len < CT_EEPROM_SIZE - start ? len : CT_EEPROM_SIZE - start);
        assert_eeprom_items_in_range(servo.table, context);
        stats->stores++;
        cut_everywhere(&port, old_area, servo.table, stats, context);
      }
    }
  }
  /* RESET from this state: factory defaults stored after the reply. */
  if (!locked) {
    port_t port = base_port;
    dxl_servo_t servo = base;
    const dxl_packet_t reset = {servo.table[CT_ADDR_ID], DXL_INST_RESET, 0, NULL, 0};
    dxl_response_t response;
    dxl_servo_handle(&servo, &reset, &response);
    dxl_after_commit(&servo, response.after, &port);
    dxl_after_reply(&servo, response.after, &port);
    assert_int_equal(port.persists, 1);
    uint8_t factory[CT_EEPROM_SIZE];
    factory_area(factory);
    assert_memory_equal(servo.table, factory, CT_EEPROM_SIZE);
    char context[256];
    snprintf(context, sizeof context, "%s: RESET", state->name);
    stats->stores++;
    cut_everywhere(&port, old_area, factory, stats, context);
  }
}

static void test_every_write_window_and_pattern_cut_at_every_byte_boots_old_or_new(void **state) {
  (void)state;
  build_states();
  stats_t stats = {0};
  for (size_t s = 0; s < STATE_COUNT; s++) {
    sweep_state(&states[s], false, &stats);
    sweep_state(&states[s], true, &stats);
  }
  print_message("%lu writes (%lu refused), %lu stores, %lu cuts and power-ups: %lu boot the old settings, %lu the new\n",
                stats.writes, stats.refused, stats.stores, stats.cuts, stats.booted_old, stats.booted_new);
  assert_true(stats.stores > 100u);
  assert_true(stats.booted_old > 0u && stats.booted_new > 0u);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_every_write_window_and_pattern_cut_at_every_byte_boots_old_or_new),
  };
  return cmocka_run_group_tests_name("settings sweep (" AX12_PROFILE_NAME ")", tests, NULL, NULL);
}
