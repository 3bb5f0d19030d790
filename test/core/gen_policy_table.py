#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Writes policy_table.h, the core's C tests' copy of the policy's control table, from the one
hand-written table of the tests (test/clients/ax12_policy.py). Run at build time by
test/core/CMakeLists.txt; the header goes to the build tree, never the sources.

Each item's power-up value is the policy's default for the built profile, and for the items
the policy leaves to the power-up (RUNTIME) what ax12_policy.AT_CORE_POWER_UP says the core
alone holds then. Nothing here comes from firmware/core/ct_items.h: the table is the check.

Usage: gen_policy_table.py POLICY_DIR OUT.h
"""
import os
import sys

ACCESS = {"R": "POL_R", "RW": "POL_RW", "-": "POL_NONE"}  # the policy's spelling -> the C table's


def c_value(policy, value):
    if value is policy.THE_BUILDS_FIRMWARE_VERSION:
        return "DXL_FIRMWARE_VERSION"
    return str(value)


def per_profile(ax12, ax12a):
    """One C expression of the value for the built profile."""
    return ax12 if ax12 == ax12a else f"POL_PICK({ax12}, {ax12a})"


def power_up(policy, item, profile):
    value = policy.default(item, profile)
    if value is policy.RUNTIME:
        if item.addr not in policy.AT_CORE_POWER_UP:
            sys.exit(f"gen_policy_table: {item.name} (address {item.addr}) is RUNTIME but "
                     "AT_CORE_POWER_UP gives no power-up value")
        value = policy.AT_CORE_POWER_UP[item.addr]
    return c_value(policy, value)


def item_row(policy, item):
    access = per_profile(ACCESS[item.access], ACCESS[policy.ACCESS_AX12A.get(item.addr, item.access)])
    low, high = (0, 0) if item.lo is None else (item.lo, item.hi)
    value = per_profile(power_up(policy, item, "ax12"), power_up(policy, item, "ax12a"))
    return f'    {{"{item.name}", {item.addr}, {item.size}, {access}, {low}, {high}, {value}}},\n'


def header(policy):
    runtime = {item.addr for item in policy.TABLE if policy.RUNTIME in (item.default_ax12, item.default_ax12a)}
    if set(policy.AT_CORE_POWER_UP) != runtime:
        sys.exit("gen_policy_table: AT_CORE_POWER_UP names addresses %s, the RUNTIME items are at %s"
                 % (sorted(policy.AT_CORE_POWER_UP), sorted(runtime)))
    rows = "".join(item_row(policy, item) for item in policy.TABLE)
    return f"""/* Generated at build time by test/core/gen_policy_table.py from test/clients/ax12_policy.py.
 * Do not edit: change the policy's table there.
 *
 * The control table of docs/policy.md for the core's tests, independent of ct_items.h, so a
 * mistake in the core's descriptor shows up as a disagreement rather than being checked
 * against itself. Access and power-up values are those of the profile the test is built for. */
#ifndef POLICY_TABLE_H
#define POLICY_TABLE_H

#include <stdint.h>

#include "dxl_config.h"

#define POL_R 0    /* read-only */
#define POL_RW 1   /* writable */
#define POL_NONE 2 /* reserved: reads 0, writes are Range Errors */

#if DXL_PROFILE == DXL_PROFILE_AX12A
#define POL_PICK(ax12, ax12a) (ax12a)
#else
#define POL_PICK(ax12, ax12a) (ax12)
#endif

/* The harness powers the core up with this Present Position. */
#define POL_PRESENT_POSITION_AT_POWER_UP {policy.PRESENT_POSITION_AT_CORE_POWER_UP}u

typedef struct {{
  const char *name;
  uint8_t addr;
  uint8_t size_bytes;
  uint8_t access;
  uint16_t min; /* min and max: the write range of a writable item, else 0 */
  uint16_t max; /* Moving Speed: joint mode; wheel mode allows POL_MOVING_SPEED_WHEEL_MAX */
  uint16_t power_up_value;
}} pol_item_t;

static const pol_item_t pol_items[] = {{
{rows}}};
#define POL_ITEM_COUNT (sizeof pol_items / sizeof pol_items[0])

#define POL_TABLE_SIZE {policy.LAST_ADDR + 1}u
#define POL_EEPROM_SIZE {policy.EEPROM_END}u
#define POL_MOVING_SPEED_WHEEL_MAX {policy.MOVING_SPEED_WHEEL_MAX}u

#endif
"""


def main(argv):
    if len(argv) != 3:
        sys.exit("usage: gen_policy_table.py POLICY_DIR OUT.h")
    sys.dont_write_bytecode = True  # nothing written beside the policy in the sources
    sys.path.insert(0, argv[1])
    import ax12_policy
    partial = argv[2] + ".partial"
    with open(partial, "w") as out:
        out.write(header(ax12_policy))
    os.replace(partial, argv[2])


if __name__ == "__main__":
    main(sys.argv)
