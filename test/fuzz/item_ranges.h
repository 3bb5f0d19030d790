/* The control table's items as ct_items.h states them for the built profile, read directly
 * (not through dxl_table.c's descriptors), so the fuzz harness and the settings sweep check
 * the core's tables against the one definition, not against the core's own reading of it. */
#ifndef ITEM_RANGES_H
#define ITEM_RANGES_H

#include <stdint.h>

#include "ct_items.h"
#include "dxl_table.h"

#if DXL_PROFILE == DXL_PROFILE_AX12A
#define PICK(ax12, ax12a) (ax12a)
#else
#define PICK(ax12, ax12a) (ax12)
#endif

typedef struct {
  const char *name;
  uint8_t addr, size, access;
  uint16_t min, max;
} item_t;

static const item_t items[] = {
#define ITEM(name, addr, size, acc, acc_a, min, max, def, def_a) {#name, (addr), (size), PICK(acc, acc_a), (min), (max)},
    CT_ITEMS(ITEM)
#undef ITEM
};
#define ITEM_COUNT (sizeof items / sizeof items[0])

#endif
