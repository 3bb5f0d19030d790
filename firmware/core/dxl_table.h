/* The control table: one flat array of 50 bytes behind one write path.
 *
 * Everything here derives from CT_ITEMS (ct_items.h): the address constants, the descriptor
 * table, defaults, range checks and the Lock rules. The table is stored little-endian as the
 * protocol sends it. Addresses 0..CT_EEPROM_SIZE-1 are the persistent area.
 */
#ifndef DXL_TABLE_H
#define DXL_TABLE_H

#include <stdbool.h>
#include <stdint.h>

#include "ct_items.h"
#include "dxl_config.h"

#define CT_SIZE 50u        /* addresses 0..49 */
#define CT_EEPROM_SIZE 24u /* addresses 0..23 persist */

enum ct_access { CT_NONE = 0, CT_R = 1, CT_RW = 2 };

/* CT_ADDR_<NAME>: the address of each item. */
enum ct_addr {
#define CT_X_ADDR(name, addr, size, acc, acc_a, min, max, def, def_a) CT_ADDR_##name = (addr),
  CT_ITEMS(CT_X_ADDR)
#undef CT_X_ADDR
};

/* CT_IDX_<NAME>: the position of each item in ct_items.h (CT_ITEM_COUNT: how many). */
enum ct_index {
#define CT_X_INDEX(name, addr, size, acc, acc_a, min, max, def, def_a) CT_IDX_##name,
  CT_ITEMS(CT_X_INDEX)
#undef CT_X_INDEX
  CT_ITEM_COUNT
};

/* The table's rules one address at a time, for the built profile (what the firmware reads):
 * a byte's access (that of its item), whether it is the low or the high byte of a 2-byte item,
 * the range of the byte alone and its factory default. A 2-byte writable item's range is
 * 0..(H << 8 | 0xFF) (checked in dxl_table.c), so "every byte within its byte range" is exactly
 * "the 16-bit value within the item's range": the low byte takes 0..255, the high byte 0..H. */
#define CT_BYTE_ACCESS_MASK 0x03u /* enum ct_access */
#define CT_BYTE_LOW_OF_PAIR 0x04u /* the low byte of a 2-byte item (its high byte follows) */
#define CT_BYTE_HIGH_OF_PAIR 0x08u
typedef struct {
  uint8_t rule; /* access | CT_BYTE_LOW_OF_PAIR | CT_BYTE_HIGH_OF_PAIR */
  uint8_t min;
  uint8_t max;
  uint8_t factory_default;
} ct_byte_t;

extern const DXL_FLASH ct_byte_t ct_bytes[CT_SIZE];

/* One item as the built profile sees it (the tests' view of ct_bytes[]). */
typedef struct {
  uint8_t addr;
  uint8_t size_bytes; /* 1 or 2 */
  uint8_t access;     /* enum ct_access */
  uint16_t min;
  uint16_t max;
  uint16_t factory_default;
} ct_desc_t;

/* The item that contains address addr (addr < CT_SIZE). */
ct_desc_t ct_item_at(uint8_t addr);

/* 16-bit items, low byte first. Inlined everywhere (a call costs more than the access). */
static inline __attribute__((always_inline)) uint16_t ct_get_u16(const uint8_t *table, uint8_t addr) {
  return (uint16_t)(table[addr] | ((uint16_t)table[addr + 1] << 8));
}

static inline __attribute__((always_inline)) void ct_set_u16(uint8_t *table, uint8_t addr, uint16_t value) {
  table[addr] = (uint8_t)(value & 0xFFu);
  table[addr + 1] = (uint8_t)(value >> 8);
}

/* Factory defaults for the whole table (the RAM area's power-up values but for the items
 * ct_set_power_up_ram() sets). */
void ct_load_factory_defaults(uint8_t *table);
/* A stored EEPROM area made safe to run (docs/policy.md "Power-up"): the items that are not
 * writable (model number, firmware version, calibration, reserved) take this firmware's
 * values, and every writable item outside the range a WRITE would accept takes its factory
 * default; the others are kept. Lock must be off in table. */
void ct_repair_stored_eeprom(uint8_t *table);
/* The power-up values of the RAM area that are not factory defaults, from the EEPROM area and
 * Present Position: Goal Position = present_position, Torque Limit = Max Torque (docs/policy.md
 * "Power-up"). */
void ct_set_power_up_ram(uint8_t *table, uint16_t present_position);

/* True when both angle limits are 0 (endless turn). */
bool ct_is_wheel_mode(const uint8_t *table);

/* The value a byte of the table would have after writing data[0..len) at start, for a window
 * that does not pass address 255 (start + len <= 256, as every window ct_check_write()
 * accepts): below start the byte offset wraps to at least 256 - start >= len, so one byte
 * compare tells whether addr lies in the window (fewer instructions on the AVR than testing
 * addr >= start and the 16-bit difference). */
static inline uint8_t ct_byte_after_write(const uint8_t *table, uint8_t addr, uint8_t start, const uint8_t *data,
                                          uint8_t len) {
  const uint8_t offset = (uint8_t)(addr - start);
  return offset < len ? data[offset] : table[addr];
}

/* The value the 16-bit item at addr would hold after writing data[0..len) at start. */
static inline uint16_t ct_u16_after_write(const uint8_t *table, uint8_t addr, uint8_t start, const uint8_t *data,
                                          uint8_t len) {
  return (uint16_t)(ct_byte_after_write(table, addr, start, data, len) |
                    ((uint16_t)ct_byte_after_write(table, (uint8_t)(addr + 1), start, data, len) << 8));
}

/* Checks a write of data[0..len) at address start as a whole, against access, range and Lock
 * rules of the built profile. Returns 0 when the whole write is acceptable, else
 * DXL_ERR_RANGE. Writes nothing. len 0 is a Range Error. */
uint8_t ct_check_write(const uint8_t *table, uint8_t start, const uint8_t *data, uint8_t len);

/* Longest window of consecutive writable addresses (for the REG_WRITE slot size). */
uint8_t ct_longest_writable_run(void);

#endif
