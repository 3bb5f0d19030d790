# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 conform`: the cases (docs/conform.md "The cases").

A case is one conformance record (python/ax12_conformance_records.py) and what came of it:
status, differences, notes, reply timings. Here too: the record's control table as its steps
change it (factory_table, apply_changes), what a case can be replayed with (classify), and
the items its starting state must hold (starting_items).
"""
import re

import ax12_conformance_records as R
import ax12_table as T
from ax12_conform_rewrite import read_window, writes_of

ITEM_AT = {}  # address -> Item, for each byte an item covers
for _item in T.ITEMS:
    for _k in range(_item.size):
        ITEM_AT[_item.addr + _k] = _item
TITLE_ADDR = {}
for _item in T.ITEMS:
    if _item.title not in TITLE_ADDR or getattr(_item, "access_ax12") == "RW":
        TITLE_ADDR[_item.title] = _item.addr
# Bytes of a READ reply no two servos share: the present values and Moving.
PRESENT = set(range(T.PRESENT_POSITION, T.PRESENT_TEMPERATURE + 1)) | {T.MOVING}
# Bytes that are the device's own: its Firmware Version (the report's header gives it). Not
# compared in READ replies or tables.
DEVICE_OWN = {T.FIRMWARE_VERSION}
# Condition bits of the error byte that come from measurements (supply voltage, temperature,
# load), which no record can foresee: not compared (a note says when the device set them).
MEASURED_CONDITIONS = T.ERR_VOLTAGE | T.ERR_OVERHEATING | T.ERR_OVERLOAD
LOCK_VALUE = 1
# EEPROM items that shape replies to packets that do not name them: the Angle Limit condition
# comes from the angle limits (for a written goal, or a speed in wheel mode), the alarms from
# the temperature and voltage limits. Set to the factory's where the device allows it.
SHAPING_EEPROM = (T.CW_ANGLE_LIMIT, T.CCW_ANGLE_LIMIT, T.HIGHEST_LIMIT_TEMP, T.LOWEST_LIMIT_VOLTAGE,
                  T.HIGHEST_LIMIT_VOLTAGE)
# Writes whose reply carries the Angle Limit condition: they need the angle limits.
NEEDS_ANGLE_LIMITS = (T.GOAL_POSITION, T.MOVING_SPEED)
# The RAM the tool sets before every round: Torque Enable .. Torque Limit, Lock, Punch.
STARTING_RAM = tuple(it.addr for it in T.ITEMS if T.TORQUE_ENABLE <= it.addr <= T.TORQUE_LIMIT) + (T.LOCK, T.PUNCH)


def access(item, profile):
    return getattr(item, "access_" + profile)


def address_name(addr):
    """'address 47 (Lock)', 'address 31 (Goal Position, high byte)'."""
    item = ITEM_AT.get(addr)
    if item is None:
        return "address %d" % addr
    if item.size == 2:
        return "address %d (%s, %s byte)" % (addr, item.title, "low" if addr == item.addr else "high")
    return "address %d (%s)" % (addr, item.title)


def item_value(table, item):
    return sum(table[item.addr + k] << (8 * k) for k in range(item.size))


def error_words(code):
    names = [(T.ERR_VOLTAGE, "voltage"), (T.ERR_ANGLE_LIMIT, "angle limit"), (T.ERR_OVERHEATING, "overheating"),
             (T.ERR_RANGE, "range"), (T.ERR_CHECKSUM, "checksum"), (T.ERR_OVERLOAD, "overload"),
             (T.ERR_INSTRUCTION, "instruction")]
    words = [n for bit, n in names if code & bit]
    return "%02X (%s)" % (code, ", ".join(words) if words else "no error")


def describe_field(f):
    left = " (left by '%s')" % f["left_by"] if f.get("left_by") else ""
    if f["field"] == "error":
        return "error byte: expected %s, heard %s" % (error_words(f["expected"]), error_words(f["heard"]))
    return "%s: expected %02X, heard %02X%s" % (f["field"], f["expected"], f["heard"], left)


def factory_table(profile, servo_id, baud_register):
    """The table of a factory-fresh servo as the core tests start it (Goal Position 512: the
    host model's Present Position at power-up; Torque Limit = Max Torque)."""
    t = [0] * T.TABLE_SIZE
    for item in T.ITEMS:
        v = getattr(item, "default_" + profile)
        for k in range(item.size):
            t[item.addr + k] = (v >> (8 * k)) & 0xFF
    t[T.ID], t[T.BAUD_RATE] = servo_id, baud_register
    t[T.GOAL_POSITION], t[T.GOAL_POSITION + 1] = 0x00, 0x02
    t[T.TORQUE_LIMIT], t[T.TORQUE_LIMIT + 1] = t[T.MAX_TORQUE], t[T.MAX_TORQUE + 1]
    return t


CHANGE = re.compile(r"^(?:ID (\d+): )?(.+) (\d+) \u2192 (\d+)$")


def change_addr(name):
    """The address of an item as the records name it ("reserved 19" for a reserved address)."""
    m = re.match(r"^reserved (\d+)$", name)
    if m:
        return int(m.group(1))
    return TITLE_ADDR.get(name)


def apply_changes(table, changes):
    for text in changes or ():
        m = CHANGE.match(text)
        if not m or change_addr(m.group(2)) is None:
            continue
        addr = change_addr(m.group(2))
        value = int(m.group(4))
        table[addr] = value & 0xFF
        if T.BY_ADDR[addr].size == 2:
            table[addr + 1] = value >> 8


def changed_addrs(changes):
    out = set()
    for text in changes or ():
        m = CHANGE.match(text)
        if m and change_addr(m.group(2)) is not None:
            addr = change_addr(m.group(2))
            out |= set(range(addr, addr + T.BY_ADDR[addr].size))
    return out


class Case:
    """One record run against the device. status: None (not run yet), "passed", "failed",
    "skipped" (skip_kind and reason say why), or "not run" (the run stopped before it)."""

    def __init__(self, record):
        self.record = record
        self.group = record["group"]
        self.name = record["name"]
        self.status = None
        self.reason = None
        self.skip_kind = None
        self.differences = []  # [{step, sent, expected, heard, bytes} or {step, note}]
        self.notes = []
        self.seconds = 0.0
        self.timings = []  # [Timing]
        self.eeprom = False
        self.rounds = R.split_rounds(record["steps"])

    def skip(self, kind, reason):
        self.status, self.skip_kind, self.reason = "skipped", kind, reason

    def differ(self, step, note, **fields):
        """A difference at step: note says it in words; fields (sent, expected, heard, bytes) give
        the bytes when there are any. The differences stay in the order of the steps (a reply's
        timing is known after the case has run)."""
        self.differences.append(dict(fields, step=step, note=note))
        self.differences.sort(key=lambda d: step_order(d["step"]))


def step_order(label):
    """The place of a step label in its case: "round 2, step 3" after "round 1, table after";
    in a round the preparation, then the steps, then the table read back."""
    m = re.match(r"^(?:round (\d+), )?(preparation|step (\d+)|table after)", label)
    if not m:
        return (0, 0, 0)
    kind = m.group(2)
    phase = 0 if kind.startswith("preparation") else 2 if kind == "table after" else 1
    return (int(m.group(1) or 0), phase, int(m.group(3) or 0))


def classify(case, profile):
    """A reason the record cannot be replayed over one port, as (kind, text), or None. Sets
    case.eeprom when a packet of the case would write the EEPROM area with a value other than
    the one the record's servo holds then (whatever the reply), or RESET."""
    steps = case.record["steps"]
    if any(s.get("via") for s in steps) or not case.rounds or case.rounds[0][0] is None:
        return "api", "the core's API without a bus: not replayable over a port"
    if any(s["kind"] == "event" for s in steps):
        return "event", "sets a condition inside the servo (not replayable over a port)"
    if any(s["kind"] == "power-cycle" for s in steps):
        return "power-cycle", "needs a power cycle"
    for bus, _ in case.rounds:
        if len(bus["ids"]) > 1:
            return "servos", "needs %d servos on the bus" % len(bus["ids"])
        if bus["temperature"] != 25:
            return "temperature", "needs the servo at %d °C" % bus["temperature"]
    for bus, rsteps in case.rounds:
        table = factory_table(profile, bus["ids"][0], bus["baud"])
        for s in rsteps:
            if s["kind"] != "exchange":
                continue
            w = writes_of(R.parse_hex(s["sent"]))
            if w == "reset":
                case.eeprom = True
            else:
                for sid, addr, value in w:
                    if addr == T.LOCK and value == LOCK_VALUE:
                        return "lock", "sets Lock, which only a power cycle clears"
                    if addr < T.EEPROM_SIZE and table[addr] != value:
                        case.eeprom = True
            apply_changes(table, s.get("changes"))
    return None


def starting_items(rsteps, profile):
    """(required, shaping): the addresses of writable items a round's starting state is made of.
    required: those it reads or writes (and Status Return Level, which decides every reply, and
    the angle limits for a write of a goal or a speed): the round means nothing without them at
    the factory's values. shaping: the rest the tool sets (the EEPROM items that shape replies,
    the RAM items): a round that does not name them still runs when the device refuses them.
    ID and Baud Rate are mapped, never set."""
    required = {T.STATUS_RETURN_LEVEL}
    for s in rsteps:
        if s["kind"] != "exchange":
            continue
        sent = R.parse_hex(s["sent"])
        window = read_window(sent)
        if window:
            required |= set(range(window[0], window[0] + window[1]))
        written = writes_of(sent)
        if written != "reset":
            addrs = {ad for _, ad, _ in written}
            required |= addrs
            if addrs & set(a for w in NEEDS_ANGLE_LIMITS for a in (w, w + 1)):
                required |= {T.CW_ANGLE_LIMIT, T.CCW_ANGLE_LIMIT}

    def items(addrs):
        out = set()
        for a in addrs:
            item = ITEM_AT.get(a)
            if item is not None and access(item, profile) == "RW" and item.addr not in (T.ID, T.BAUD_RATE) \
                    and item.addr != T.REGISTERED_INSTRUCTION:
                out.add(item.addr)
        return out

    required = items(required)
    shaping = items(SHAPING_EEPROM + STARTING_RAM) - required
    return sorted(required), sorted(shaping)
