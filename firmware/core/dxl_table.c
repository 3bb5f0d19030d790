#include "dxl_table.h"

#include "dxl_protocol.h"

#if DXL_PROFILE == DXL_PROFILE_AX12A
#define CT_PICK(ax12, ax12a) (ax12a)
#else
#define CT_PICK(ax12, ax12a) (ax12)
#endif

/* ct_bytes[]: one entry per byte of each item (token pasting on the item's size, 1 or 2). */
#define CT_X_BYTES(name, addr, size, acc, acc_a, min, max, def, def_a) \
  CT_BYTES_##size(addr, CT_PICK(acc, acc_a), min, max, CT_PICK(def, def_a))
#define CT_BYTES_1(addr, access, min, max, def) [(addr)] = {(access), (min), (max), (def)},
#define CT_BYTES_2(addr, access, min, max, def) \
  [(addr)] = {(access) | CT_BYTE_LOW_OF_PAIR, (min) & 0xFFu, (max) & 0xFFu, (def) & 0xFFu}, \
  [(addr) + 1] = {(access) | CT_BYTE_HIGH_OF_PAIR, (min) >> 8, (max) >> 8, (def) >> 8},
const DXL_FLASH ct_byte_t ct_bytes[CT_SIZE] = {CT_ITEMS(CT_X_BYTES)};
#undef CT_BYTES_1
#undef CT_BYTES_2
#undef CT_X_BYTES

/* Byte by byte is the item's rule (dxl_table.h): a 1-byte item's range fits a byte, and a
 * 2-byte writable item's runs from 0 to a value whose low byte is 0xFF, in both profiles. */
#define CT_X_BYTEWISE(name, addr, size, acc, acc_a, min, max, def, def_a)                                      \
  _Static_assert((size) == 1 ? (max) <= 255 && (def) <= 255 && (def_a) <= 255                                  \
                             : ((acc) != CT_RW && (acc_a) != CT_RW) || ((min) == 0 && ((max) & 0xFFu) == 0xFFu), \
                 "CT_ITEMS: the range of " #name " cannot be checked byte by byte");
CT_ITEMS(CT_X_BYTEWISE)
#undef CT_X_BYTEWISE

ct_desc_t ct_item_at(uint8_t addr) {
  if (ct_bytes[addr].rule & CT_BYTE_HIGH_OF_PAIR) {
    addr--;
  }
  const ct_byte_t low = ct_bytes[addr];
  ct_desc_t d = {addr, 1, low.rule & CT_BYTE_ACCESS_MASK, low.min, low.max, low.factory_default};
  if (low.rule & CT_BYTE_LOW_OF_PAIR) {
    const ct_byte_t high = ct_bytes[addr + 1];
    d.size_bytes = 2;
    d.min = (uint16_t)(d.min | high.min << 8);
    d.max = (uint16_t)(d.max | high.max << 8);
    d.factory_default = (uint16_t)(d.factory_default | high.factory_default << 8);
  }
  return d;
}

/* docs/policy.md "Lock (address 47)": which addresses a locked table still accepts. */
#define LOCK_AX12_WRITABLE_FIRST CT_ADDR_TORQUE_ENABLE     /* 24 */
#define LOCK_AX12_WRITABLE_LAST (CT_ADDR_TORQUE_LIMIT + 1) /* 35 */
#define LOCK_AX12A_REFUSED_FIRST CT_ADDR_ID                /* 3 */
#define LOCK_AX12A_REFUSED_LAST (CT_EEPROM_SIZE - 1)       /* 23 */

/* Moving Speed's range in wheel mode: bits 0..9 speed, bit 10 direction. */
#define MOVING_SPEED_WHEEL_MAX 2047u
_Static_assert((MOVING_SPEED_WHEEL_MAX & 0xFFu) == 0xFFu, "Moving Speed's wheel range byte by byte");

void ct_load_factory_defaults(uint8_t *table) {
  const DXL_FLASH ct_byte_t *rules = ct_bytes;
  for (uint8_t addr = 0; addr < CT_SIZE; addr++, rules++) {
    table[addr] = rules->factory_default;
  }
}

/* A byte takes its default when its item, as the table holds it, would not pass a WRITE
 * (not writable, or out of range): its low byte first, then its high byte, which the item's
 * check still refuses (only a high byte can be out of a 2-byte item's range), so a bad item
 * takes its whole default. */
void ct_repair_stored_eeprom(uint8_t *table) {
  for (uint8_t addr = 0; addr < CT_EEPROM_SIZE; addr++) {
    if (ct_check_write(table, addr, &table[addr], 1) != 0) {
      table[addr] = ct_bytes[addr].factory_default;
    }
  }
}

void ct_set_power_up_ram(uint8_t *table, uint16_t present_position) {
  ct_set_u16(table, CT_ADDR_PRESENT_POSITION, present_position);
  ct_set_u16(table, CT_ADDR_GOAL_POSITION, present_position);
  ct_set_u16(table, CT_ADDR_TORQUE_LIMIT, ct_get_u16(table, CT_ADDR_MAX_TORQUE));
}

bool ct_is_wheel_mode(const uint8_t *table) {
  if (ct_get_u16(table, CT_ADDR_CW_ANGLE_LIMIT) != 0) { /* two returns, not one &&: smaller on the ATmega88 */
    return false;
  }
  return ct_get_u16(table, CT_ADDR_CCW_ANGLE_LIMIT) == 0;
}

/* Whether a locked table refuses a write to addr (no item straddles a bound below). */
static bool locked_refuses(uint8_t addr) {
#if DXL_PROFILE == DXL_PROFILE_AX12A
  if (addr < LOCK_AX12A_REFUSED_FIRST) {
    return false;
  }
  return addr <= LOCK_AX12A_REFUSED_LAST;
#else
  if (addr < LOCK_AX12_WRITABLE_FIRST) {
    return true;
  }
  return addr > LOCK_AX12_WRITABLE_LAST;
#endif
}

/* Every byte of every item the window touches against its access, Lock and its byte range
 * (dxl_table.h), as the table would hold it after the write: the window's last item whole,
 * its first from the window's start (the low byte of a 2-byte item before it would pass: same
 * access and Lock as its high byte, and the range 0..255). */
uint8_t ct_check_write(const uint8_t *table, uint8_t start, const uint8_t *data, uint8_t len) {
  if (len == 0 || start >= CT_SIZE || len > (uint8_t)(CT_SIZE - start)) {
    return DXL_ERR_RANGE;
  }
  const bool locked = table[CT_ADDR_LOCK] != 0;
  uint8_t addr = start;
  uint8_t last = (uint8_t)(start + len - 1u);
  if (ct_bytes[last].rule & CT_BYTE_LOW_OF_PAIR) {
    last++;
  }
  for (const DXL_FLASH ct_byte_t *rules = &ct_bytes[addr]; addr <= last; addr++, rules++) {
    const ct_byte_t b = *rules;
    if ((b.rule & CT_BYTE_ACCESS_MASK) != CT_RW || (locked && locked_refuses(addr))) {
      return DXL_ERR_RANGE;
    }
    uint8_t max = b.max;
    if (addr == CT_ADDR_MOVING_SPEED + 1u) {
      if ((ct_u16_after_write(table, CT_ADDR_CW_ANGLE_LIMIT, start, data, len) |
           ct_u16_after_write(table, CT_ADDR_CCW_ANGLE_LIMIT, start, data, len)) == 0) {
        /* wheel mode after the write (both limits 0, one OR: smaller than an &&) */
        max = MOVING_SPEED_WHEEL_MAX >> 8;
      }
    }
    const uint8_t value = ct_byte_after_write(table, addr, start, data, len);
    if (value < b.min || value > max) {
      return DXL_ERR_RANGE;
    }
  }
  return 0;
}

uint8_t ct_longest_writable_run(void) {
  uint8_t longest = 0;
  uint8_t run = 0;
  for (uint8_t addr = 0; addr < CT_SIZE; addr++) {
    run = ((ct_bytes[addr].rule & CT_BYTE_ACCESS_MASK) == CT_RW) ? (uint8_t)(run + 1) : 0;
    if (run > longest) {
      longest = run;
    }
  }
  return longest;
}
