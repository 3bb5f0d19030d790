#include "dxl_table.h"

#include "dxl_protocol.h"

#if DXL_PROFILE == DXL_PROFILE_AX12A
#define CT_PICK(ax12, ax12a) (ax12a)
#else
#define CT_PICK(ax12, ax12a) (ax12)
#endif

const DXL_FLASH ct_desc_t ct_items[CT_ITEM_COUNT] = {
#define CT_X_DESC(name, addr, size, acc, acc_a, min, max, def, def_a) \
  {(addr), (size), CT_PICK(acc, acc_a), (min), (max), CT_PICK(def, def_a)},
    CT_ITEMS(CT_X_DESC)
#undef CT_X_DESC
};

/* Every minimum fits ct_desc_t.min (uint8_t). */
#define CT_X_MIN_FITS(name, addr, size, acc, acc_a, min, max, def, def_a) \
  _Static_assert((min) <= 255, "CT_ITEMS: minimum of " #name " does not fit ct_desc_t.min");
CT_ITEMS(CT_X_MIN_FITS)
#undef CT_X_MIN_FITS

/* Address -> item index, so a write or read window is walked item by item in O(items). */
static const DXL_FLASH uint8_t item_index_by_addr[CT_SIZE] = {
#define CT_X_INDEX_BY_ADDR(name, addr, size, acc, acc_a, min, max, def, def_a) \
  [(addr)...((addr) + (size)-1)] = CT_IDX_##name,
    CT_ITEMS(CT_X_INDEX_BY_ADDR)
#undef CT_X_INDEX_BY_ADDR
};

/* docs/policy.md "Lock (address 47)": which addresses a locked table still accepts. */
#define LOCK_AX12_WRITABLE_FIRST CT_ADDR_TORQUE_ENABLE     /* 24 */
#define LOCK_AX12_WRITABLE_LAST (CT_ADDR_TORQUE_LIMIT + 1) /* 35 */
#define LOCK_AX12A_REFUSED_FIRST CT_ADDR_ID                /* 3 */
#define LOCK_AX12A_REFUSED_LAST (CT_EEPROM_SIZE - 1)       /* 23 */

/* Moving Speed's range in wheel mode: bits 0..9 speed, bit 10 direction. */
#define MOVING_SPEED_WHEEL_MAX 2047u

uint8_t ct_item_index_at(uint8_t addr) { return item_index_by_addr[addr]; }

/* Factory defaults into items first_addr..end_addr-1; with keep_valid_settings, a writable
 * item whose value is inside its range (ct_check_write on an unlocked table) is kept. */
static void load_defaults(uint8_t *table, uint8_t first_addr, uint8_t end_addr, bool keep_valid_settings) {
  for (uint8_t i = 0; i < CT_ITEM_COUNT; i++) {
    const ct_desc_t d = ct_items[i];
    if (d.addr < first_addr || d.addr >= end_addr ||
        (keep_valid_settings && d.access == CT_RW && ct_check_write(table, d.addr, &table[d.addr], d.size_bytes) == 0)) {
      continue;
    }
    if (d.size_bytes == 2) {
      ct_set_u16(table, d.addr, d.factory_default);
    } else {
      table[d.addr] = (uint8_t)d.factory_default;
    }
  }
}

void ct_load_factory_eeprom(uint8_t *table) { load_defaults(table, 0, CT_EEPROM_SIZE, false); }

void ct_repair_stored_eeprom(uint8_t *table) { load_defaults(table, 0, CT_EEPROM_SIZE, true); }

void ct_load_power_up_ram(uint8_t *table, uint16_t present_position) {
  load_defaults(table, CT_EEPROM_SIZE, CT_SIZE, false);
  ct_set_u16(table, CT_ADDR_PRESENT_POSITION, present_position);
  ct_set_u16(table, CT_ADDR_GOAL_POSITION, present_position);
  ct_set_u16(table, CT_ADDR_TORQUE_LIMIT, ct_get_u16(table, CT_ADDR_MAX_TORQUE));
}

bool ct_is_wheel_mode(const uint8_t *table) {
  if (ct_get_u16(table, CT_ADDR_CW_ANGLE_LIMIT) != 0) { /* two returns, not one &&: smaller code */
    return false;
  }
  return ct_get_u16(table, CT_ADDR_CCW_ANGLE_LIMIT) == 0;
}

/* Two returns, not one && or ||: smaller on the ATmega88. */
static bool locked_refuses(uint8_t first_addr, uint8_t last_addr) {
#if DXL_PROFILE == DXL_PROFILE_AX12A
  if (last_addr < LOCK_AX12A_REFUSED_FIRST) {
    return false;
  }
  return first_addr <= LOCK_AX12A_REFUSED_LAST;
#else
  if (first_addr < LOCK_AX12_WRITABLE_FIRST) {
    return true;
  }
  return last_addr > LOCK_AX12_WRITABLE_LAST;
#endif
}

/* The value item (addr, size_bytes) would hold after writing data[0..len) at start: a 1-byte
 * item as the low byte of the 16-bit read (one path: smaller on the ATmega88). The
 * table ends with a 2-byte item, so addr + 1 of a 1-byte item is in the table. */
_Static_assert(CT_ADDR_PUNCH + 2u == CT_SIZE, "the last item has 2 bytes");
static uint16_t item_value_after_write(const uint8_t *table, uint8_t addr, uint8_t size_bytes, uint8_t start,
                                       const uint8_t *data, uint8_t len) {
  const uint16_t value = ct_u16_after_write(table, addr, start, data, len);
  return size_bytes == 2 ? value : (uint8_t)value;
}

uint8_t ct_check_write(const uint8_t *table, uint8_t start, const uint8_t *data, uint8_t len) {
  if (len == 0 || start >= CT_SIZE || len > (uint8_t)(CT_SIZE - start)) {
    return DXL_ERR_RANGE;
  }
  const bool locked = table[CT_ADDR_LOCK] != 0;
  const uint8_t end = (uint8_t)(start + len);
  uint8_t pos = start;
  while (pos < end) {
    const uint8_t index = ct_item_index_at(pos);
    const ct_desc_t d = ct_items[index];
    const uint8_t last_addr = (uint8_t)(d.addr + d.size_bytes - 1);
    if (d.access != CT_RW || (locked && locked_refuses(d.addr, last_addr))) {
      return DXL_ERR_RANGE;
    }
    uint16_t max = d.max;
    if (index == CT_IDX_MOVING_SPEED) {
      if ((ct_u16_after_write(table, CT_ADDR_CW_ANGLE_LIMIT, start, data, len) |
           ct_u16_after_write(table, CT_ADDR_CCW_ANGLE_LIMIT, start, data, len)) == 0) {
        /* wheel mode after the write (both limits 0, one OR: smaller than an &&) */
        max = MOVING_SPEED_WHEEL_MAX;
      }
    }
    const uint16_t value = item_value_after_write(table, d.addr, d.size_bytes, start, data, len);
    if (value < d.min || value > max) {
      return DXL_ERR_RANGE;
    }
    pos = (uint8_t)(last_addr + 1);
  }
  return 0;
}

uint8_t ct_longest_writable_run(void) {
  uint8_t longest = 0;
  uint8_t run = 0;
  for (uint8_t addr = 0; addr < CT_SIZE; addr++) {
    run = (ct_items[ct_item_index_at(addr)].access == CT_RW) ? (uint8_t)(run + 1) : 0;
    if (run > longest) {
      longest = run;
    }
  }
  return longest;
}
