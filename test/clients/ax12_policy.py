"""The AX-12 control table as docs/policy.md states it: the tests' one hand-written table.

Written from the spec on purpose (not generated from firmware/core/ct_items.h), so the tests
check the firmware against the policy rather than against itself. The client suites import it;
test_ct_items_match_the_policy.py compares it item by item with ax12_table (generated from
ct_items.h at build time); and the core's C tests get it as policy_table.h, which
test/core/gen_policy_table.py writes from this module at build time.
"""
from collections import namedtuple

Item = namedtuple("Item", "addr size access name lo hi default_ax12 default_ax12a")

R, RW, NONE = "R", "RW", "-"
RUNTIME = object()   # filled at power-up or measured

# addr, bytes, access (ax12), name, write range, default ax12, default ax12a
TABLE = [
    Item(0, 2, R, "Model Number", None, None, 12, 12),
    Item(2, 1, R, "Firmware Version", None, None, RUNTIME, RUNTIME),
    Item(3, 1, RW, "ID", 0, 253, 1, 1),
    Item(4, 1, RW, "Baud Rate", 0, 254, 1, 1),
    Item(5, 1, RW, "Return Delay Time", 0, 254, 250, 250),
    Item(6, 2, RW, "CW Angle Limit", 0, 1023, 0, 0),
    Item(8, 2, RW, "CCW Angle Limit", 0, 1023, 1023, 1023),
    Item(10, 1, NONE, "reserved 10", None, None, 0, 0),
    Item(11, 1, RW, "Highest Limit Temperature", 0, 150, 85, 70),
    Item(12, 1, RW, "Lowest Limit Voltage", 50, 250, 60, 60),
    Item(13, 1, RW, "Highest Limit Voltage", 50, 250, 190, 140),
    Item(14, 2, RW, "Max Torque", 0, 1023, 1023, 1023),
    Item(16, 1, RW, "Status Return Level", 0, 2, 2, 2),
    Item(17, 1, RW, "Alarm LED", 0, 127, 4, 36),
    Item(18, 1, RW, "Alarm Shutdown", 0, 127, 4, 36),
    Item(19, 1, RW, "reserved 19", 0, 1, 0, 0),
    Item(20, 2, R, "Down Calibration", None, None, RUNTIME, RUNTIME),
    Item(22, 2, R, "Up Calibration", None, None, RUNTIME, RUNTIME),
    Item(24, 1, RW, "Torque Enable", 0, 1, 0, 0),
    Item(25, 1, RW, "LED", 0, 1, 0, 0),
    Item(26, 1, RW, "CW Compliance Margin", 0, 254, 0, 1),
    Item(27, 1, RW, "CCW Compliance Margin", 0, 254, 0, 1),
    Item(28, 1, RW, "CW Compliance Slope", 1, 254, 32, 32),
    Item(29, 1, RW, "CCW Compliance Slope", 1, 254, 32, 32),
    Item(30, 2, RW, "Goal Position", 0, 1023, RUNTIME, RUNTIME),
    Item(32, 2, RW, "Moving Speed", 0, 1023, 0, 0),  # joint mode; wheel mode: MOVING_SPEED_WHEEL_MAX
    Item(34, 2, RW, "Torque Limit", 0, 1023, RUNTIME, RUNTIME),
    Item(36, 2, R, "Present Position", None, None, RUNTIME, RUNTIME),
    Item(38, 2, R, "Present Speed", None, None, RUNTIME, RUNTIME),
    Item(40, 2, R, "Present Load", None, None, RUNTIME, RUNTIME),
    Item(42, 1, R, "Present Voltage", None, None, RUNTIME, RUNTIME),
    Item(43, 1, R, "Present Temperature", None, None, RUNTIME, RUNTIME),
    Item(44, 1, RW, "Registered Instruction", 0, 1, 0, 0),
    Item(45, 1, NONE, "reserved 45", None, None, 0, 0),
    Item(46, 1, R, "Moving", None, None, 0, 0),
    Item(47, 1, RW, "Lock", 1, 1, 0, 0),
    Item(48, 2, RW, "Punch", 0, 1023, 32, 32),
]
BY_ADDR = {it.addr: it for it in TABLE}
LAST_ADDR = 49          # a READ/WRITE window may not reach past this address
EEPROM_END = 24         # 0..23 EEPROM, 24..49 RAM
# Profile ax12a (the AX-12A e-manual): where its access differs from the ax12 column.
ACCESS_AX12A = {44: R}  # Registered Instruction is read-only
MOVING_SPEED_WHEEL_MAX = 2047  # Moving Speed's max when both angle limits are 0

# What each RUNTIME item holds right after the protocol core alone powers up (docs/policy.md
# "Power-up"), as the core's host tests power it up: Present Position
# PRESENT_POSITION_AT_CORE_POWER_UP and no control layer, so nothing is measured.
# THE_BUILDS_FIRMWARE_VERSION stands for the version number of the build under test.
PRESENT_POSITION_AT_CORE_POWER_UP = 512
THE_BUILDS_FIRMWARE_VERSION = object()
AT_CORE_POWER_UP = {
    2: THE_BUILDS_FIRMWARE_VERSION,
    20: 0,                                  # factory calibration: the ideal lower end
    22: 1023,                               # and the ideal upper end
    30: PRESENT_POSITION_AT_CORE_POWER_UP,  # Goal Position = Present Position
    34: 1023,                               # Torque Limit = Max Torque
    36: PRESENT_POSITION_AT_CORE_POWER_UP,
    38: 0, 40: 0, 42: 0, 43: 0,             # Present Speed, Load, Voltage, Temperature
}

# Error byte bits
ERROR_BITS = {0x01: "Input Voltage", 0x02: "Angle Limit", 0x04: "Overheating", 0x08: "Range",
              0x10: "Checksum", 0x20: "Overload", 0x40: "Instruction"}
ERROR_CONDITIONS = {0x01, 0x02, 0x04, 0x20}  # set while true; the others only in one reply


def default(item, profile):
    return item.default_ax12 if profile == "ax12" else item.default_ax12a


def baud_of(value):
    """Baud Rate register value -> bits per second (docs/policy.md: 2 000 000 / (value + 1))."""
    return 2_000_000 / (value + 1)


def parse_ids(spec):
    """'1-6' -> [1..6]; '1,3,5-7' -> [1, 3, 5, 6, 7]."""
    out = []
    for part in str(spec).split(","):
        if "-" in part:
            a, b = part.split("-")
            out.extend(range(int(a), int(b) + 1))
        else:
            out.append(int(part))
    return out
