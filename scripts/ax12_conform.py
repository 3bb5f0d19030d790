#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Checks a Dynamixel Protocol 1.0 device on a serial port against the AX-12 conformance suite
(`scripts/ax12 conform`; docs/conform.md).

The cases are the conformance records of the core's host tests (the reply matrix, the write
ranges, the error paths and the conversations of test/conversations): the records
docs/conformance.md is rendered from, read through python/ax12_conformance_records.py. Each
record is replayed against the device: its servo's ID becomes --id, its other IDs become IDs
checked to be silent, its baud register the device's; every packet is rewritten (ID bytes,
IDs and bauds carried as data, checksums, a bad checksum kept bad by the same amount). Every
reply must come back byte for byte but for the present values (position, speed, load, voltage,
temperature, Moving), which no two servos share; after each case the device's table is read
back and the items the case wrote or changed must hold what the record says.

Safe by default: the whole table is read first; cases that would write the EEPROM area with
another value, the ID or the baud need --allow-eeprom; every setting changed is written back
after each such case and at exit, also after Ctrl-C or SIGTERM and when the device stops
answering (it is looked for at the IDs and bauds the case used). Cases that set Lock are not
run (only a power cycle clears it).

Exit status: 0 every case run passed; 1 a case failed; 2 bad arguments, no port, no device;
3 refused (two devices at the ID, device locked); 4 a setting could not be restored;
130 interrupted (settings restored).
"""
import argparse
import json
import os
import re
import select
import signal
import statistics
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "python"))

EXIT_FAILED, EXIT_USAGE, EXIT_REFUSED, EXIT_RESTORE, EXIT_INTERRUPTED = 1, 2, 3, 4, 130

GROUP_NAMES = {"matrix": "reply matrix", "reply matrix": "reply matrix", "ranges": "write ranges",
               "write ranges": "write ranges", "errors": "error paths", "error paths": "error paths",
               "conversations": "conversations"}
BITS_PER_BYTE = 10  # 8N1
# Baud Rate registers of the usual bauds (1 Mbps, 500k, 400k, 250k, 200k, 115200, 57600, 19200,
# 9600): where a device that cannot be found is looked for last.
COMMON_BAUDS = (1, 3, 4, 7, 9, 16, 34, 103, 207)
# A reply that is due but late is still waited for this long past --timeout (and reported as
# late): an emulator on a busy host can fall behind the wall clock for tens of milliseconds.
GRACE_S = 0.5
EEPROM_BYTE_S = 0.0045  # an AVR EEPROM byte takes 3.4 ms; the image's CRC and version come with it


class Refused(Exception):
    pass


class Problem(Exception):
    """Bad input or an unusable device: a clear message, no traceback."""


class Interrupted(Exception):
    pass


# --- arguments -----------------------------------------------------------------------------------

def arguments(argv):
    p = argparse.ArgumentParser(prog="scripts/ax12 conform", description=__doc__.split("\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="See docs/conform.md for what is compared and how the device is kept safe.")
    p.add_argument("--port", required=True, help="the serial device (e.g. /dev/ttyUSB0, or the pty of scripts/ax12 serve)")
    p.add_argument("--id", type=int, default=1, help="the device's ID (default 1)")
    p.add_argument("--baud", type=int, default=1000000,
                   help="the device's baud: bit/s, or a Baud Rate register value 0..254 (default 1000000)")
    p.add_argument("--profile", choices=("ax12", "ax12a"), default="ax12",
                   help="which AX-12 to compare with: ax12 (2006 manual, default) or ax12a")
    p.add_argument("--only", action="append", default=[], metavar="GROUP",
                   help="run one group: matrix, ranges, errors, conversations (repeatable)")
    p.add_argument("--case", action="append", default=[], metavar="TEXT",
                   help="run only cases whose name contains TEXT (repeatable)")
    p.add_argument("--allow-eeprom", action="store_true",
                   help="also run cases that write the EEPROM area, the ID or the baud (restored afterwards)")
    p.add_argument("--report", action="append", default=[], metavar="FILE",
                   help="write a report: FILE.md (Markdown) or FILE.json (machine-readable); repeatable")
    p.add_argument("--timeout", type=float, default=0.05,
                   help="seconds to wait for a reply after a request has left (default 0.05; "
                        "raise it for USB adapters with a long latency timer)")
    p.add_argument("--build", default=os.path.join(REPO, "build"),
                   help="the build holding the core tests the cases come from (default build/)")
    p.add_argument("--verbose", "-v", action="store_true", help="print every exchange to stderr as it happens")
    args = p.parse_args(argv)
    if not 0 <= args.id <= 253:
        p.error("--id must be 0..253")
    if 0 <= args.baud <= 254:
        args.baud_register = args.baud
    elif args.baud >= 7843:
        args.baud_register = max(0, min(254, round(2000000 / args.baud) - 1))
    else:
        p.error("--baud: give bit/s (7843..2000000) or a Baud Rate register value (0..254)")
    for g in args.only:
        if g.lower() not in GROUP_NAMES:
            p.error("--only: unknown group '%s' (matrix, ranges, errors, conversations)" % g)
    if args.timeout <= 0:
        p.error("--timeout must be positive")
    for r in args.report:
        if not (r.endswith(".md") or r.endswith(".json")):
            p.error("--report: the file name must end in .md or .json: %s" % r)
    return args


ARGS = arguments(sys.argv[1:])
import ax12_build  # noqa: E402
ax12_build.use(ARGS.build)
import ax12_table as T  # noqa: E402
import ax12_packets as P  # noqa: E402
import ax12_conformance_records as R  # noqa: E402
import serial  # noqa: E402  (pyserial)


def bps_of(register):
    return 2000000.0 / (register + 1)


def hexs(data):
    return " ".join("%02X" % b for b in data)


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


def access(item, profile):
    return getattr(item, "access_" + profile)


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


# --- packets: what a sent packet writes, and rewriting IDs and bauds ------------------------------

def frame(data):
    """(header length, ID, LENGTH, end) of a packet's bytes, or None when they are not exactly one
    packet by its LENGTH."""
    h = 0
    while h < len(data) and data[h] == T.HEADER_BYTE:
        h += 1
    if h < 2 or h + 2 > len(data):
        return None
    end = h + 2 + data[h + 1]
    if end != len(data) or data[h + 1] < 2:
        return None
    return h, data[h], data[h + 1], end


def writes_of(data):
    """[(address, value)] a well-formed instruction packet would write, per servo slice for
    SYNC_WRITE (ID None for WRITE and REG_WRITE): [(id, address, value)]; 'reset' for RESET."""
    f = frame(data)
    if f is None:
        return []
    h, ident, length, end = f
    code, params = data[h + 2], data[h + 3:end - 1]
    out = []
    if code in (T.INST_WRITE, T.INST_REG_WRITE) and len(params) >= 2:
        out = [(None, params[0] + i, v) for i, v in enumerate(params[1:])]
    elif code == T.INST_SYNC_WRITE and len(params) >= 2 and params[1] > 0 and (len(params) - 2) % (params[1] + 1) == 0:
        size = params[1]
        for k in range((len(params) - 2) // (size + 1)):
            s = params[2 + k * (size + 1):2 + (k + 1) * (size + 1)]
            out += [(s[0], params[0] + i, v) for i, v in enumerate(s[1:])]
    elif code == T.INST_RESET:
        return "reset"
    return out


def read_window(data):
    f = frame(data)
    if f is None:
        return None
    h, ident, length, end = f
    if data[h + 2] == T.INST_READ and end - h - 4 == 2:
        return data[h + 3], data[h + 4]
    return None


def ids_in(data):
    """IDs a packet carries: its header's, SYNC_WRITE's slices', an ID written as data."""
    out = set()
    f = frame(data)
    if f is None:
        h = 0
        while h < len(data) and data[h] == T.HEADER_BYTE:
            h += 1
        if h >= 2 and h < len(data):
            out.add(data[h])
        return out
    out.add(f[1])
    w = writes_of(data)
    if w != "reset":
        for sid, addr, value in w:
            if sid is not None:
                out.add(sid)
            if addr == T.ID:
                out.add(value)
    return out


def remap(data, idmap, baudmap, window=None):
    """The packet's bytes with IDs (header, SYNC_WRITE slices, ID written or read as data) and
    Baud Rate values (written or read) mapped, and its checksum recomputed off by as much as
    the original's was. window: the (start, length) of the READ a status packet answers.
    None when the bytes are not one packet and need a mapping that is not the identity."""
    data = list(data)
    f = frame(data)
    if f is None:
        h = 0
        while h < len(data) and data[h] == T.HEADER_BYTE:
            h += 1
        if h >= 2 and h < len(data) and idmap.get(data[h], data[h]) != data[h]:
            return None
        return data
    h, ident, length, end = f
    body = data[h:end - 1]
    delta = (data[end - 1] - P.checksum(body)) & 0xFF
    new = list(body)
    new[0] = idmap.get(ident, ident)
    code = body[2]
    params = new[3:]

    def at(addr, value):
        if addr == T.ID:
            return idmap.get(value, value)
        if addr == T.BAUD_RATE:
            return baudmap.get(value, value)
        return value

    if window is not None:
        if len(params) == window[1]:
            params = [at(window[0] + i, v) for i, v in enumerate(params)]
    elif code in (T.INST_WRITE, T.INST_REG_WRITE) and len(params) >= 2:
        params = params[:1] + [at(params[0] + i, v) for i, v in enumerate(params[1:])]
    elif code == T.INST_SYNC_WRITE and len(params) >= 2 and params[1] > 0 and (len(params) - 2) % (params[1] + 1) == 0:
        size = params[1]
        out = params[:2]
        for k in range((len(params) - 2) // (size + 1)):
            s = params[2 + k * (size + 1):2 + (k + 1) * (size + 1)]
            out += [idmap.get(s[0], s[0])] + [at(params[0] + i, v) for i, v in enumerate(s[1:])]
        params = out
    new = new[:3] + params
    return data[:h] + new + [(P.checksum(new) + delta) & 0xFF]


# --- the port ------------------------------------------------------------------------------------

class Port:
    def __init__(self, path, register):
        if not os.path.exists(path):
            raise Problem("no such port: %s" % path)
        try:
            self.s = serial.Serial(path, int(round(bps_of(register))), timeout=0, write_timeout=2)
        except (serial.SerialException, OSError, ValueError) as e:
            raise Problem("cannot open %s: %s" % (path, e))
        self.path = path
        self.register = register
        self.fd = self.s.fileno()

    def set_register(self, register):
        if register != self.register:
            try:
                self.s.baudrate = int(round(bps_of(register)))
            except (serial.SerialException, OSError, ValueError) as e:
                raise Problem("the port cannot switch to %d bit/s: %s" % (bps_of(register), e))
            self.register = register

    @property
    def bps(self):
        return bps_of(self.register)

    def drain(self):
        out = b""
        while True:
            r, _, _ = select.select([self.fd], [], [], 0)
            if not r:
                return out
            chunk = os.read(self.fd, 4096)
            if not chunk:
                return out
            out += chunk

    def exchange(self, data, expect_len, timeout, quiet=0.001, grace=0.0):
        """Sends data; collects what comes back until expect_len bytes (or more) and a quiet
        gap, or until timeout after the request's end (when expect_len bytes are due, grace
        seconds longer). Returns (bytes, request end, arrival of the first byte or None).

        Not ax12_servo_port's transact() or ServoPort: a conformance case judges what those
        leave out, so this one times the request's end and the first byte's arrival (the
        reply's delay), keeps listening after expect_len bytes for a quiet gap (an extra or a
        duplicated reply is a finding, not noise), and allows for the longest Return Delay
        Time at the port's current bit rate."""
        data = bytes(data)
        t_send = time.monotonic()
        os.write(self.fd, data)
        t_end = t_send + len(data) * BITS_PER_BYTE / self.bps
        got = b""
        t_first = None
        # the longest Return Delay Time (254 x 2 us) and the reply's own bytes come on top
        deadline = t_end + timeout + 0.000508 + max(expect_len, 6) * BITS_PER_BYTE / self.bps
        if expect_len > 0:
            deadline += grace
        while True:
            now = time.monotonic()
            if len(got) >= expect_len > 0:
                wait = quiet
            else:
                wait = deadline - now
                if wait <= 0:
                    break
            r, _, _ = select.select([self.fd], [], [], max(wait, 0))
            if not r:
                if len(got) >= expect_len > 0:
                    break
                continue
            chunk = os.read(self.fd, 4096)
            if chunk:
                if t_first is None:
                    t_first = time.monotonic()
                got += chunk
        return got, t_end, t_first

    def close(self):
        try:
            self.s.close()
        except (serial.SerialException, OSError):
            pass

    def kind(self):
        real = os.path.realpath(self.path)
        if re.match(r"^/dev/pts/\d+$", real):
            return "pty"
        base = os.path.basename(real)
        latency = "/sys/bus/usb-serial/devices/%s/latency_timer" % base
        if os.path.exists(latency):
            try:
                with open(latency) as f:
                    return "usb-serial (latency timer %s ms)" % f.read().strip()
            except OSError:
                pass
            return "usb-serial"
        if base.startswith("ttyACM"):
            return "usb-cdc"
        return "serial"


# --- the device ----------------------------------------------------------------------------------

class Device:
    """The device under test and the talk to it outside the cases: PING, READ, WRITE."""

    def __init__(self, port, ident, timeout):
        self.port = port
        self.id = ident
        self.timeout = timeout

    def ping(self, ident=None, grace=0.0):
        self.port.drain()  # nothing late from before may pass for the reply
        packet = P.instruction_packet(self.id if ident is None else ident, T.INST_PING, [])
        got, _, _ = self.port.exchange(packet, 6, self.timeout, grace=grace)
        p = P.parse(got)
        if p is None or not p.checksum_ok:
            return None if not got else got
        return p

    def read(self, addr, count, ident=None):
        ident = self.id if ident is None else ident
        self.port.drain()
        packet = P.instruction_packet(ident, T.INST_READ, [addr, count])
        got, _, _ = self.port.exchange(packet, 6 + count, self.timeout, grace=GRACE_S)
        p = P.parse(got)
        if p is None or not p.checksum_ok or p.ident != ident or len(p.params) != count:
            return None
        return list(p.params)

    def write(self, addr, values, ident=None, answered=True):
        """WRITE; returns the status packet, or None when silent. answered: whether a reply is
        due (Status Return Level 2): only then is a late one waited for."""
        ident = self.id if ident is None else ident
        self.port.drain()
        eeprom = sum(1 for k in range(len(values)) if addr + k < T.EEPROM_SIZE)
        extra = EEPROM_BYTE_S * (eeprom + 2) if eeprom else 0.0
        packet = P.instruction_packet(ident, T.INST_WRITE, [addr] + list(values))
        got, _, _ = self.port.exchange(packet, 6, self.timeout + extra, grace=GRACE_S if answered else 0.0)
        if eeprom and not got:
            time.sleep(extra)  # silent: let the EEPROM write end before the next packet
        return P.parse(got)


# --- cases ---------------------------------------------------------------------------------------

class Case:
    def __init__(self, record):
        self.record = record
        self.group = record["group"]
        self.name = record["name"]
        self.status = None  # passed, failed, skipped
        self.reason = None  # why skipped
        self.skip_kind = None
        self.differences = []  # [{step, sent, expected, heard, note}]
        self.notes = []
        self.seconds = 0.0
        self.timings = []  # [(reply start after the request's end s, RDT s)]
        self.eeprom = False
        self.rounds = R.split_rounds(record["steps"])

    def skip(self, kind, reason):
        self.status, self.skip_kind, self.reason = "skipped", kind, reason


def classify(case, profile):
    """A reason the record cannot be replayed over one port, or None. Sets case.eeprom when a
    packet of the case would write the EEPROM area with a value other than the one the record's
    servo holds then (whatever the reply), or RESET."""
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
            sent = R.parse_hex(s["sent"])
            w = writes_of(sent)
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


# --- the run -------------------------------------------------------------------------------------

class Conform:
    def __init__(self, args):
        self.args = args
        self.profile = args.profile
        self.port = None
        self.dev = None
        self.original = None
        self.table = None  # the device's table as last known
        self.free_ids = []
        self.restore_problems = []
        self.warnings = []
        self.cases = []
        self.touched_eeprom = False
        self.where = None  # (id, register) the device is expected at now
        self.written = set()  # (id, register) it may have been moved to
        self.case_ids, self.case_bauds = set(), set()  # where the case running may move the device

    def say(self, text):
        print(text, file=sys.stderr, flush=True)

    def verbose(self, text):
        if self.args.verbose:
            self.say(text)

    # -- finding and checking the device --

    def start(self):
        a = self.args
        self.port = Port(a.port, a.baud_register)
        self.dev = Device(self.port, a.id, a.timeout)
        self.where = (a.id, a.baud_register)
        self.port.drain()
        first = self.dev.ping()
        if first is None:
            raise Problem("no device answers a PING at ID %d at %d bit/s on %s (wrong ID, baud or port? "
                          "check --id and --baud)" % (a.id, bps_of(a.baud_register), a.port))
        self.check_single(first)
        table = self.dev.read(0, T.TABLE_SIZE)
        if table is None:
            raise Problem("ID %d answers PING but not a READ of the control table (Status Return Level 0, "
                          "or not an AX-12-like table); the tool needs READ" % a.id)
        self.original = list(table)
        self.table = list(table)
        if table[T.ID] != a.id:
            raise Problem("the device at ID %d reads ID %d at address 3" % (a.id, table[T.ID]))
        if table[T.BAUD_RATE] != a.baud_register:
            # the port's baud is what works; take the register the device reports as its own
            self.warnings.append("the device reads Baud Rate %d; --baud gave %d" % (table[T.BAUD_RATE], a.baud_register))
        if table[T.LOCK] == LOCK_VALUE:
            raise Refused("the device is locked (Lock = 1): only a power cycle clears it, and locked it refuses "
                          "most of the suite; power it off and on and run again")
        if first.code != 0:
            self.warnings.append("the device's PING reply has error byte %02X before any case: a condition "
                                 "holds, and every reply will carry it" % first.code)
        self.find_free_ids()

    def check_single(self, first):
        """Refuses when two devices answer at the ID: a unicast PING must bring one clean status
        packet, a broadcast PING no two packets of one ID and nothing garbled."""
        a = self.args
        for attempt in range(2):
            got, _, _ = self.port.exchange(P.instruction_packet(a.id, T.INST_PING, []), 0, a.timeout)
            packets = P.split(got)
            if got and (packets is None or len(packets) != 1 or not P.parse(packets[0]).checksum_ok
                        or P.parse(packets[0]).ident != a.id):
                raise Refused("more than one device answers at ID %d: a PING brought %s (a collision or two "
                              "status packets); give every device its own ID and run again" % (a.id, hexs(got)))
        if isinstance(first, (bytes, bytearray)):
            raise Refused("more than one device answers at ID %d: a PING brought %s (a collision or two "
                          "status packets); give every device its own ID and run again" % (a.id, hexs(first)))
        got, _, _ = self.port.exchange(P.instruction_packet(T.ID_BROADCAST, T.INST_PING, []), 0, a.timeout * 3)
        packets = P.split(got) if got else []
        if packets is None or any(not P.parse(p).checksum_ok for p in packets):
            raise Refused("a broadcast PING brought garbled bytes (%s): two devices answered at once; "
                          "give every device its own ID and run again" % hexs(got))
        ids = [P.parse(p).ident for p in packets]
        if ids.count(a.id) > 1:
            raise Refused("a broadcast PING brought %d replies from ID %d: two devices share the ID; "
                          "give every device its own ID and run again" % (ids.count(a.id), a.id))
        self.others = sorted(set(ids) - {a.id})
        if self.others:
            self.warnings.append("other devices answer on this bus: IDs %s" % ", ".join(map(str, self.others)))

    def find_free_ids(self):
        """IDs the records use as 'another ID' (and a few spares), each checked to be silent."""
        wanted = []
        for r in self.records:
            for s in r["steps"]:
                if s["kind"] == "exchange":
                    wanted += sorted(ids_in(R.parse_hex(s["sent"])))
                if s["kind"] == "bus":
                    wanted += s["ids"]
        candidates = []
        for i in list(dict.fromkeys(wanted)) + [200, 201, 202, 203]:
            if i not in candidates and i != T.ID_BROADCAST and i != self.args.id and 0 <= i <= T.ID_MAX:
                candidates.append(i)
        for i in candidates:
            if i in getattr(self, "others", []):
                continue
            if self.dev.ping(i) is None:
                self.free_ids.append(i)

    # -- one case --

    def mapping(self, case):
        """(idmap, baudmap) for the record, or a reason it cannot be mapped."""
        bus0 = case.rounds[0][0]
        servo = bus0["ids"][0]
        ids, bauds = set(), set()
        for bus, rsteps in case.rounds:
            ids.add(bus["ids"][0])
            bauds.add(bus["baud"])
            for s in rsteps:
                if s["kind"] == "exchange":
                    for text in (s["sent"], s["heard"]):
                        for pk in (P.split(R.parse_hex(text)) or [R.parse_hex(text)]):
                            ids |= ids_in(pk)
                    w = writes_of(R.parse_hex(s["sent"]))
                    if w != "reset":
                        bauds |= {v for _, a, v in w if a == T.BAUD_RATE}
                if s["kind"] == "master-baud":
                    bauds.add(s["baud"])
        idmap = {servo: self.args.id, T.ID_BROADCAST: T.ID_BROADCAST}
        spare = [i for i in self.free_ids if i not in ids]
        for i in sorted(ids - {servo, T.ID_BROADCAST}):
            if i > T.ID_MAX:
                idmap[i] = i
            elif i in self.free_ids and i != self.args.id:
                idmap[i] = i
            elif spare:
                idmap[i] = spare.pop(0)
            else:
                return None, None, "no silent ID to stand for ID %d" % i
        dev_baud = self.original[T.BAUD_RATE]
        baudmap = {bus0["baud"]: dev_baud}
        for b in bauds - {bus0["baud"]}:
            if b == dev_baud:
                return None, None, "uses Baud Rate %d, the device's own, as another baud" % b
            baudmap[b] = b
        return idmap, baudmap, None

    def needs(self, case, rsteps):
        """EEPROM addresses whose factory value the round depends on: those that shape every
        reply (Status Return Level, the angle limits, the temperature and voltage limits) and
        those its READs read, and those it writes (read back after it). ID and Baud Rate are
        mapped, not needed."""
        addrs = {T.STATUS_RETURN_LEVEL, T.CW_ANGLE_LIMIT, T.CW_ANGLE_LIMIT + 1, T.CCW_ANGLE_LIMIT,
                 T.CCW_ANGLE_LIMIT + 1, T.HIGHEST_LIMIT_TEMP, T.LOWEST_LIMIT_VOLTAGE, T.HIGHEST_LIMIT_VOLTAGE}
        for s in rsteps:
            if s["kind"] == "exchange":
                sent = R.parse_hex(s["sent"])
                w = read_window(sent)
                if w:
                    addrs |= set(range(w[0], min(w[0] + w[1], T.EEPROM_SIZE)))
                written = writes_of(sent)
                if written != "reset":
                    addrs |= {ITEM_AT[ad].addr + k for _, ad, _ in written if ad in ITEM_AT
                              for k in range(ITEM_AT[ad].size)}
        return sorted(a for a in addrs if a < T.EEPROM_SIZE and a not in (T.ID, T.BAUD_RATE)
                      and access(ITEM_AT[a], self.profile) == "RW")

    def run_case(self, case):
        idmap, baudmap, why = self.mapping(case)
        if why:
            case.skip("mapping", why)
            return
        self.case_ids = {i for i in idmap.values() if i != T.ID_BROADCAST} | {1}
        self.case_bauds = set(baudmap.values()) | {1}
        # malformed packets carry IDs that cannot be rewritten
        for bus, rsteps in case.rounds:
            for s in rsteps:
                if s["kind"] == "exchange" and remap(R.parse_hex(s["sent"]), idmap, baudmap) is None:
                    case.skip("mapping", "sends a malformed packet for ID %d: run with --id %d"
                              % (bus["ids"][0], bus["ids"][0]))
                    return
        # a RESET that takes effect puts the device at ID 1, 1 Mbps; steps after it need the map to agree
        plans = []
        for bus, rsteps in case.rounds:
            factory = factory_table(self.profile, bus["ids"][0], bus["baud"])
            needed = self.needs(case, rsteps)
            differ = [a for a in needed if self.table[a] != factory[a]]
            if differ and not self.args.allow_eeprom:
                names = sorted({ITEM_AT[a].title for a in differ})
                case.skip("eeprom", "needs --allow-eeprom: the device's %s differ%s from the factory value%s the "
                          "case assumes" % (", ".join(names), "s" if len(names) == 1 else "",
                                            "" if len(names) == 1 else "s"))
                return
            plans.append((bus, rsteps, factory, differ))
        for bus, rsteps, factory, differ in plans:
            for k, s in enumerate(rsteps):
                if s["kind"] == "exchange" and writes_of(R.parse_hex(s["sent"])) == "reset" and \
                        any(t["kind"] == "exchange" for t in rsteps[k + 1:]) and \
                        (idmap.get(1, 1) != 1 or baudmap.get(1, 1) != 1):
                    case.skip("mapping", "steps after a RESET need the device at ID 1 and 1 Mbps")
                    return
        if (case.eeprom or any(p[3] for p in plans)) and not self.args.allow_eeprom:
            case.skip("eeprom", "needs --allow-eeprom: writes the EEPROM area (%s)" % self.eeprom_items(case))
            return
        case.status = "passed"
        for number, (bus, rsteps, factory, differ) in enumerate(plans, 1):
            self.run_round(case, number, bus, rsteps, factory, differ, idmap, baudmap)
            if (case.eeprom or differ) and not self.restore(final=False):
                case.status = "failed"
                raise Problem("the device stopped answering during '%s' and could not be found again" % case.name)
        if case.differences:
            case.status = "failed"

    def eeprom_items(self, case):
        names = []
        for bus, rsteps in case.rounds:
            for s in rsteps:
                if s["kind"] == "exchange":
                    w = writes_of(R.parse_hex(s["sent"]))
                    if w == "reset":
                        names.append("RESET")
                    else:
                        names += [ITEM_AT[a].title for _, a, _ in w if a < T.EEPROM_SIZE and a in ITEM_AT]
        return ", ".join(dict.fromkeys(names)) or "EEPROM"

    def prepare(self, case, factory, differ):
        """The round's starting state: factory values for the EEPROM items it needs (differ), and
        for the RAM items (Goal Position 512, as the records)."""
        dev = self.dev
        problems = []
        if self.table[T.REGISTERED_INSTRUCTION]:
            # a write left registered by the case before: discarded by writing 0 where the
            # device allows it, else run by ACTION (and what it wrote restored)
            reply = dev.write(T.REGISTERED_INSTRUCTION, [0], answered=self.table[T.STATUS_RETURN_LEVEL] >= 2)
            if reply is None or reply.code & T.ERR_RANGE:
                self.port.exchange(P.instruction_packet(self.args.id, T.INST_ACTION, []), 6, self.args.timeout,
                                   grace=GRACE_S)
                table = dev.read(0, T.TABLE_SIZE)
                if table is None or table[:T.EEPROM_SIZE] != self.table[:T.EEPROM_SIZE]:
                    self.touched_eeprom = True
                    self.restore(final=False)
                else:
                    self.table = table
        items = sorted({ITEM_AT[a].addr for a in differ}, key=lambda ad: ad != T.STATUS_RETURN_LEVEL)
        for addr in items:  # Status Return Level first: the others' replies depend on it
            item = T.BY_ADDR[addr]
            self.touched_eeprom = True
            answered = self.table[T.STATUS_RETURN_LEVEL] >= 2
            reply = dev.write(addr, factory[addr:addr + item.size], answered=answered)
            self.table[addr:addr + item.size] = factory[addr:addr + item.size]
            if answered and (reply is None or reply.code & ~T.ERR_CONDITIONS):
                problems.append("WRITE of %s" % item.title)
        ram = factory[T.TORQUE_ENABLE:T.TORQUE_LIMIT + 2]
        reply = dev.write(T.TORQUE_ENABLE, ram)
        if reply is None or reply.code & ~T.ERR_CONDITIONS:
            problems.append("WRITE of addresses 24..35")
        reply = dev.write(T.PUNCH, factory[T.PUNCH:T.PUNCH + 2])
        if reply is None or reply.code & ~T.ERR_CONDITIONS:
            problems.append("WRITE of Punch")
        return problems

    def run_round(self, case, number, bus, rsteps, factory, differ, idmap, baudmap):
        a = self.args
        problems = self.prepare(case, factory, differ)
        if problems:
            case.differences.append({"step": "preparation", "note": "the device refused the starting state: %s"
                                     % ", ".join(problems)})
            return
        table = list(factory)  # the record's servo, as its changes go
        where_id, where_baud = a.id, self.original[T.BAUD_RATE]
        self.where = (where_id, where_baud)
        checked = set()
        for index, s in enumerate(rsteps, 1):
            label = "%s%d" % ("round %d, step " % number if len(case.rounds) > 1 else "step ", index)
            if s["kind"] == "master-baud":
                self.port.set_register(baudmap.get(s["baud"], s["baud"]))
                continue
            if s["kind"] != "exchange":
                continue
            sent_rec = R.parse_hex(s["sent"])
            sent = remap(sent_rec, idmap, baudmap)
            window = read_window(sent_rec)
            expected = []
            mask = []  # per byte, the bits not compared
            heard_rec = R.parse_hex(s["heard"])
            for pk in (P.split(heard_rec) or ([heard_rec] if heard_rec else [])):
                m = remap(pk, idmap, baudmap, window)
                expected += m
                ignore = [0] * len(m)
                if len(m) >= P.SHORTEST and frame(m):
                    ignore[frame(m)[0] + 2] = MEASURED_CONDITIONS
                if window and len(pk) == 6 + window[1]:
                    for i in range(window[1]):
                        if window[0] + i in PRESENT | DEVICE_OWN:
                            ignore[5 + i] = 0xFF
                ignore[-1] = 0xFF  # the checksum follows them: checked for validity instead
                mask += ignore
            w = writes_of(sent_rec)
            eeprom_bytes = T.EEPROM_SIZE if w == "reset" else sum(1 for _, ad, _ in w if ad < T.EEPROM_SIZE)
            extra = EEPROM_BYTE_S * (eeprom_bytes + 2) if eeprom_bytes else 0.0
            if w == "reset" or any(ad < T.EEPROM_SIZE for _, ad, _ in (w if w != "reset" else [])):
                self.touched_eeprom = True
            stray = self.port.drain()
            if stray:
                case.differences.append({"step": label, "note": "%d byte(s) arrived after the previous step's "
                                         "timeout: %s" % (len(stray), hexs(stray))})
            got, t_end, t_first = self.port.exchange(sent, len(expected), a.timeout + extra, grace=GRACE_S)
            self.verbose("%s | %s: sent %s, expected %s, heard %s" % (case.name, label, hexs(sent),
                                                                       hexs(expected) or "silence", hexs(got) or "silence"))
            ok = len(got) == len(expected) and all((g ^ e) & ~m & 0xFF == 0 for g, e, m in zip(got, expected, mask))
            if ok and expected:
                ok = all(P.parse(pk) is not None and P.parse(pk).checksum_ok for pk in P.split(got) or [got])
            if not ok:
                case.differences.append({
                    "step": label, "sent": hexs(sent),
                    "expected": " ".join("%02X" % e if m != 0xFF or k == len(expected) - 1 else ".."
                                         for k, (e, m) in enumerate(zip(expected, mask))),
                    "heard": hexs(got)})
            elif got:
                held = [b for k, b in enumerate(got) if mask[k] == MEASURED_CONDITIONS and b & MEASURED_CONDITIONS]
                if held:
                    case.notes.append("%s: the device reported condition bits %02X (supply, temperature or load; "
                                      "not compared)" % (label, held[0] & MEASURED_CONDITIONS))
            if got and t_first is not None:
                # the reply's first byte began one byte time before it arrived
                start = t_first - BITS_PER_BYTE / self.port.bps - t_end
                if not eeprom_bytes:  # a reply to an EEPROM write comes once it is stored
                    case.timings.append((label, start, table[T.RETURN_DELAY_TIME] * T.RETURN_DELAY_UNIT_US * 1e-6,
                                         start > a.timeout + 0.000508))
            if not got and eeprom_bytes:
                time.sleep(extra)
            # where the device is now, as the record says
            before_id = table[T.ID]
            before = self.where
            effective_reset = False
            if w == "reset":
                f = frame(sent_rec)
                pk = P.parse(sent_rec)
                if f and pk and pk.checksum_ok and not pk.params and pk.ident in (table[T.ID], T.ID_BROADCAST):
                    heard = P.parse(heard_rec) if heard_rec else None
                    effective_reset = not (heard and heard.code & T.ERR_INSTRUCTION) and not table[T.LOCK]
            apply_changes(table, s.get("changes"))
            checked |= changed_addrs(s.get("changes"))
            if w != "reset":
                checked |= {ITEM_AT[ad].addr for sid, ad, _ in w if (sid is None or sid == before_id) and ad in ITEM_AT}
            if effective_reset:
                # the whole table is the factory's now, but Goal Position (= Present Position)
                where_id, where_baud = 1, 1
                self.written.add((1, 1))
                checked = {it.addr for it in T.ITEMS if access(it, self.profile) == "RW"} - {T.GOAL_POSITION}
            else:
                where_id = idmap.get(table[T.ID], table[T.ID])
                where_baud = baudmap.get(table[T.BAUD_RATE], table[T.BAUD_RATE])
            if (where_id, where_baud) != before:
                self.written.add((where_id, where_baud))
            self.where = (where_id, where_baud)
        self.check_after(case, number, table, checked, idmap, baudmap)

    def check_after(self, case, number, table, checked, idmap, baudmap):
        """The items the round wrote or changed, read back: they must hold what the record says."""
        where_id, where_baud = self.where
        label = "round %d, table after" % number if len(case.rounds) > 1 else "table after"
        stray = self.port.drain()
        if stray:
            case.differences.append({"step": label, "note": "%d byte(s) arrived after the last step's timeout: %s"
                                     % (len(stray), hexs(stray))})
        self.port.set_register(where_baud)
        if table[T.STATUS_RETURN_LEVEL] == 0:
            # to read it back: the level it had (or 1), so that restoring it costs nothing more
            self.dev.write(T.STATUS_RETURN_LEVEL, [max(1, self.original[T.STATUS_RETURN_LEVEL])], ident=where_id,
                           answered=False)
            self.touched_eeprom = True
            checked = checked - {T.STATUS_RETURN_LEVEL}
        got = self.dev.read(0, T.TABLE_SIZE, ident=where_id)
        if got is None:
            case.differences.append({"step": label, "note": "no reply to a READ of the table at ID %d, %d bit/s"
                                     % (where_id, bps_of(where_baud))})
            return
        self.table = list(got)
        expect = list(table)
        expect[T.ID], expect[T.BAUD_RATE] = where_id, where_baud
        wrong = []
        for addr in sorted(checked):
            item = ITEM_AT.get(addr)
            if (item is None or addr != item.addr or addr in PRESENT | DEVICE_OWN
                    or access(item, self.profile) == "NONE"):
                continue
            want = sum(expect[item.addr + k] << (8 * k) for k in range(item.size))
            have = sum(got[item.addr + k] << (8 * k) for k in range(item.size))
            if want != have:
                wrong.append("%s %d expected, %d read" % (item.title, want, have))
        if wrong:
            case.differences.append({"step": label, "note": "; ".join(wrong)})

    # -- restoring --

    def locate(self):
        """(id, register) where the device answers a PING now, trying where it should be, where it
        was found, the factory ID and baud, and where the cases moved it; None when nowhere."""
        orig = (self.args.id, self.original[T.BAUD_RATE])
        cands = [self.where, orig, (1, 1), (self.where[0], orig[1]), (orig[0], self.where[1]), (1, orig[1])]
        cands += sorted(self.written)
        ids = {c[0] for c in cands} | self.case_ids
        bauds = {c[1] for c in cands} | self.case_bauds | set(COMMON_BAUDS)
        cands += [(i, b) for b in sorted(bauds) for i in sorted(ids)]
        for attempt in range(3):
            for ident, reg in dict.fromkeys(cands):
                try:
                    self.port.set_register(reg)
                except Problem:
                    continue
                self.port.drain()
                p = self.dev.ping(ident)
                if p is not None and not isinstance(p, (bytes, bytearray)) and p.ident == ident:
                    return ident, reg
            time.sleep(0.1)
        return None

    def restore(self, final):
        """Writes back every setting of the original table that differs (EEPROM; RAM too when
        final), the ID and the baud last, and checks by reading it back."""
        orig = self.original
        loc = self.locate()
        if loc is None:
            self.restore_problems.append("the device does not answer at ID %d or any ID and baud the run used; "
                                         "it may be at an ID or baud the tool did not try" % self.args.id)
            return False
        ident, reg = loc
        table = self.dev.read(0, T.TABLE_SIZE, ident=ident)
        if table is None:  # Status Return Level 0: answers PING only
            self.dev.write(T.STATUS_RETURN_LEVEL, [max(orig[T.STATUS_RETURN_LEVEL], 1)], ident=ident, answered=False)
            table = self.dev.read(0, T.TABLE_SIZE, ident=ident)
        if table is None:
            self.restore_problems.append("the device answers PING at ID %d but not READ" % ident)
            return False
        addrs = [it for it in T.ITEMS if it.addr < T.EEPROM_SIZE and access(it, self.profile) == "RW"
                 and it.addr not in (T.ID, T.BAUD_RATE)]
        if final:
            addrs += [it for it in T.ITEMS if it.addr >= T.EEPROM_SIZE and access(it, self.profile) == "RW"
                      and it.addr not in (T.LOCK, T.REGISTERED_INSTRUCTION)]
        # Status Return Level first when it silences replies, then the rest
        addrs.sort(key=lambda it: it.addr != T.STATUS_RETURN_LEVEL or table[T.STATUS_RETURN_LEVEL] >= 2)
        level = table[T.STATUS_RETURN_LEVEL]
        for it in addrs:
            want = orig[it.addr:it.addr + it.size]
            if table[it.addr:it.addr + it.size] != want:
                self.dev.write(it.addr, want, ident=ident, answered=level >= 2)
                if it.addr == T.STATUS_RETURN_LEVEL:
                    level = want[0]
        if table[T.ID] != orig[T.ID] or ident != orig[T.ID]:
            self.dev.write(T.ID, [orig[T.ID]], ident=ident, answered=level >= 2)
            ident = orig[T.ID]
        if table[T.BAUD_RATE] != orig[T.BAUD_RATE]:
            self.dev.write(T.BAUD_RATE, [orig[T.BAUD_RATE]], ident=ident, answered=level >= 2)
            time.sleep(0.01)
        self.port.set_register(orig[T.BAUD_RATE])
        self.port.drain()
        self.where = (orig[T.ID], orig[T.BAUD_RATE])
        back = self.dev.read(0, T.TABLE_SIZE, ident=orig[T.ID])
        if back is None:
            self.restore_problems.append("after restoring, ID %d does not answer a READ at %d bit/s"
                                         % (orig[T.ID], bps_of(orig[T.BAUD_RATE])))
            return False
        self.table = list(back)
        wrong = [it.title for it in addrs if back[it.addr:it.addr + it.size] != orig[it.addr:it.addr + it.size]]
        if wrong:
            self.restore_problems.append("could not restore %s" % ", ".join(wrong))
            return False
        if final and back[T.REGISTERED_INSTRUCTION] and not orig[T.REGISTERED_INSTRUCTION]:
            self.warnings.append("a registered write is left in the device (RAM; gone at the next power-up)")
        return True

    # -- everything --

    def run(self, records):
        self.records = records
        self.cases = [Case(r) for r in records]
        self.start()
        for case in self.cases:
            why = classify(case, self.profile)
            if why:
                case.skip(*why)
        for n, case in enumerate(self.cases, 1):
            if case.status == "skipped":
                continue
            self.say("[%d/%d] %s: %s" % (n, len(self.cases), case.group, case.name)) if self.args.verbose else None
            started = time.monotonic()
            self.run_case(case)
            case.seconds = time.monotonic() - started
            if case.status == "failed":
                self.verbose("  FAILED: %s" % first_difference(case))

    def finish(self):
        """Restores everything at the end (also after an interruption or an error)."""
        if self.original is None or self.port is None:
            return True
        try:
            self.port.drain()
            return self.restore(final=True)
        except (OSError, serial.SerialException, Problem) as e:
            self.restore_problems.append("the port failed while restoring: %s" % e)
            return False


def first_difference(case):
    if not case.differences:
        return ""
    d = case.differences[0]
    if "heard" in d:
        return "%s: sent %s, expected %s, heard %s" % (d["step"], d["sent"], d["expected"] or "silence",
                                                      d["heard"] or "silence")
    return "%s: %s" % (d["step"], d["note"])


# --- reports -------------------------------------------------------------------------------------

EARLY_S = 0.0001  # a reply starting this much before the Return Delay Time has passed is early


def timing_summary(cases):
    starts = [(s, rdt, late) for c in cases for _, s, rdt, late in c.timings]
    if not starts:
        return None
    errs = [s - rdt for s, rdt, _ in starts]
    return {"replies": len(starts),
            "reply_start_minus_rdt_us": {"min": round(min(errs) * 1e6), "median": round(statistics.median(errs) * 1e6),
                                         "max": round(max(errs) * 1e6)},
            "early": sum(1 for e in errs if e < -EARLY_S),
            "late": sum(1 for _, _, late in starts if late)}


def summarise(conform, records_profile, interrupted):
    a = conform.args
    groups = []
    for g in R.GROUPS:
        cs = [c for c in conform.cases if c.group == g]
        if not cs:
            continue
        groups.append({"group": g, "passed": sum(c.status == "passed" for c in cs),
                       "failed": sum(c.status == "failed" for c in cs),
                       "skipped": sum(c.status == "skipped" for c in cs),
                       "not_run": sum(c.status is None for c in cs)})
    skipped = {}
    for c in conform.cases:
        if c.status == "skipped":
            skipped.setdefault(c.skip_kind, []).append(c)
    return {
        "tool": "scripts/ax12 conform",
        "port": a.port, "port_kind": conform.port.kind() if conform.port else None,
        "id": a.id, "baud_register": conform.original[T.BAUD_RATE] if conform.original else a.baud_register,
        "profile": records_profile, "allow_eeprom": a.allow_eeprom,
        "device": {"model": (conform.original[0] | conform.original[1] << 8) if conform.original else None,
                   "firmware": conform.original[2] if conform.original else None,
                   "return_delay_time": conform.original[T.RETURN_DELAY_TIME] if conform.original else None},
        "groups": groups,
        "totals": {k: sum(g[k] for g in groups) for k in ("passed", "failed", "skipped", "not_run")},
        "skipped_reasons": {k: len(v) for k, v in sorted(skipped.items())},
        "timing": timing_summary(conform.cases),
        "restored": not conform.restore_problems,
        "restore_problems": conform.restore_problems,
        "warnings": conform.warnings,
        "interrupted": interrupted,
        "cases": [{"group": c.group, "name": c.name, "status": c.status or "not run",
                   "eeprom": c.eeprom, "reason": c.reason, "differences": c.differences,
                   "notes": c.notes, "seconds": round(c.seconds, 3),
                   "replies": [{"step": label, "start_us": round(st * 1e6), "return_delay_us": round(rdt * 1e6)}
                               for label, st, rdt, _ in c.timings]} for c in conform.cases],
    }


SKIP_WORDS = {"eeprom": "write the EEPROM area: run with --allow-eeprom",
              "power-cycle": "power-cycle the servo (not over a port)",
              "servos": "need more than one servo on the bus",
              "event": "set a condition inside the servo (not over a port)",
              "api": "call the core's API directly (no bus)",
              "lock": "set Lock (only a power cycle clears it)",
              "temperature": "need the servo at another temperature",
              "mapping": "cannot be mapped to this device's ID and baud (see the JSON report)"}


def text_summary(s, conform):
    lines = []
    dev = s["device"]
    lines.append("ax12 conform: %s (%s), ID %d at %d bit/s, compared with profile %s"
                 % (s["port"], s["port_kind"], s["id"], bps_of(s["baud_register"]), s["profile"]))
    if dev["model"] is not None:
        lines.append("device: model number %d, firmware %d, Return Delay Time %d (%d us)"
                     % (dev["model"], dev["firmware"], dev["return_delay_time"], dev["return_delay_time"] * 2))
    lines.append("")
    lines.append("%-14s %7s %7s %8s" % ("group", "passed", "failed", "skipped"))
    for g in s["groups"]:
        lines.append("%-14s %7d %7d %8d%s" % (g["group"], g["passed"], g["failed"], g["skipped"],
                                             "  (%d not run)" % g["not_run"] if g["not_run"] else ""))
    t = s["totals"]
    lines.append("%-14s %7d %7d %8d" % ("total", t["passed"], t["failed"], t["skipped"]))
    if s["skipped_reasons"]:
        lines.append("skipped:")
        for k, n in sorted(s["skipped_reasons"].items(), key=lambda kv: (-kv[1], kv[0])):
            lines.append("  %3d %s" % (n, SKIP_WORDS.get(k, k)))
    failed = [c for c in conform.cases if c.status == "failed"]
    if failed:
        lines.append("")
        lines.append("failures (the first difference of each):")
        for c in failed:
            lines.append("- %s / %s" % (c.group, c.name))
            lines.append("    %s" % first_difference(c))
    tm = s["timing"]
    if tm:
        r = tm["reply_start_minus_rdt_us"]
        lines.append("")
        lines.append("timing: %d replies started %+d..%+d us (median %+d) from the request's end plus the Return "
                     "Delay Time; %d early (by over %d us), %d late (past --timeout)"
                     % (tm["replies"], r["min"], r["max"], r["median"], tm["early"], EARLY_S * 1e6, tm["late"]))
        lines.append("        (%s)" % timing_note(s["port_kind"]))
    for w in s["warnings"]:
        lines.append("warning: " + w)
    if s["restore_problems"]:
        lines.append("")
        for p in s["restore_problems"]:
            lines.append("NOT RESTORED: " + p)
    else:
        lines.append("settings: every setting the run changed was written back and read back")
    if s["interrupted"]:
        lines.append("interrupted: the cases not run are counted as not run")
    lines.append("result: %s" % ("FAIL" if t["failed"] else "PASS" if not s["interrupted"] else "INTERRUPTED"))
    return "\n".join(lines)


def timing_note(kind):
    if kind == "pty":
        return "a pty: the arrival times carry the emulator's pacing and the host's scheduling, a few hundred us"
    if kind and kind.startswith("usb-serial"):
        return ("a USB adapter: bytes reach the host when the latency timer expires or its buffer fills, so "
                "reply starts are only known to about the latency timer")
    return "a serial port: the arrival times carry the driver's and the host's scheduling"


def markdown_report(s, conform):
    lines = ["# AX-12 conformance of the device on %s" % s["port"], "", "```", text_summary(s, conform), "```", ""]
    lines += ["| group | case | result | first difference or reason |", "|---|---|---|---|"]
    for c in conform.cases:
        detail = first_difference(c) if c.status == "failed" else (c.reason or "")
        lines.append("| %s | %s | %s | %s |" % (c.group, c.name, c.status or "not run", detail.replace("|", "\\|")))
    return "\n".join(lines) + "\n"


def write_reports(s, conform):
    for path in conform.args.report:
        try:
            with open(path, "w", encoding="utf-8") as f:
                if path.endswith(".json"):
                    json.dump(s, f, indent=1, ensure_ascii=False)
                    f.write("\n")
                else:
                    f.write(markdown_report(s, conform))
        except OSError as e:
            print("ax12 conform: cannot write %s: %s" % (path, e), file=sys.stderr)


# --- main ----------------------------------------------------------------------------------------

def load_records(args):
    try:
        records = R.run_tests(os.path.abspath(args.build), (args.profile,))
    except R.RecordsError as e:
        raise Problem("the cases come from the core tests: %s" % e)
    groups = {GROUP_NAMES[g.lower()] for g in args.only}
    out = []
    for r in records:
        if groups and r["group"] not in groups:
            continue
        if args.case and not any(t.lower() in r["name"].lower() for t in args.case):
            continue
        out.append(r)
    if not out:
        raise Problem("no case matches --only/--case")
    return out


def on_signal(signum, frame):
    raise Interrupted(signal.Signals(signum).name)


def main():
    args = ARGS
    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    conform = Conform(args)
    interrupted = False
    code = 0
    try:
        try:
            records = load_records(args)
            conform.run(records)
        except Interrupted as e:
            interrupted = True
            print("ax12 conform: interrupted (%s): restoring the device's settings" % e, file=sys.stderr)
        finally:
            # nothing interrupts the restoring
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
            restored = conform.finish()
    except Refused as e:
        print("ax12 conform: refused: %s" % e, file=sys.stderr)
        return EXIT_REFUSED
    except (Problem, OSError, serial.SerialException) as e:
        if isinstance(e, Problem):
            print("ax12 conform: %s" % e, file=sys.stderr)
        else:
            print("ax12 conform: the port %s failed: %s (did the device, its adapter or the emulator behind "
                  "it go away?)" % (args.port, e), file=sys.stderr)
        if conform.restore_problems:
            for p in conform.restore_problems:
                print("ax12 conform: NOT RESTORED: %s" % p, file=sys.stderr)
            return EXIT_RESTORE
        return EXIT_USAGE
    summary = summarise(conform, args.profile, interrupted)
    print(text_summary(summary, conform))
    write_reports(summary, conform)
    if not restored:
        code = EXIT_RESTORE
    elif interrupted:
        code = EXIT_INTERRUPTED
    elif summary["totals"]["failed"]:
        code = EXIT_FAILED
    if conform.port:
        conform.port.close()
    return code


if __name__ == "__main__":
    sys.exit(main())
