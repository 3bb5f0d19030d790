# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 conform`: the connection to the device under test (docs/conform.md).

Port: the serial port, its bit rate, and one timed exchange (the request's end, the first
reply byte's arrival, and where the request sits in everything the tool has written, for the
emulator's bus clock: python/ax12_conform_bus_clock.py). Device: PING, READ and WRITE outside
the cases. Packets are built and framed by python/ax12_packets.py.
"""
import os
import re
import select
import time
from collections import namedtuple

import serial  # pyserial

import ax12_packets as P
import ax12_table as T

BITS_PER_BYTE = 10  # 8N1
# A reply that is due but late is still waited for this long past --timeout (and reported as
# late): an emulator on a busy host can fall behind the wall clock for tens of milliseconds.
GRACE_S = 0.5
EEPROM_BYTE_S = 0.0045  # an AVR EEPROM byte takes 3.4 ms; the image's CRC and version come with it
LONGEST_RDT_S = 0.000508  # Return Delay Time 254
# On the emulator's bus: how often the simulation's time is asked while it is behind the wall
# clock, and how far behind it may fall before a reply counts as missing all the same.
BUS_POLL_S = 0.02
BUS_PATIENCE_S = 30.0

# data: the bytes heard; request_end: when the request's last stop bit left (time.monotonic(),
# computed from the write and the bit rate); first_arrival: when the first byte came, or None;
# sent_end: the request's end as an offset in everything written (Port.sent).
Heard = namedtuple("Heard", "data request_end first_arrival sent_end")


class Problem(Exception):
    """Bad input or an unusable device: a clear message, no traceback."""


def bps_of(register):
    return 2000000.0 / (register + 1)


def hexs(data):
    return " ".join("%02X" % b for b in data)


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
        self.sent = bytearray()  # every byte written, in order
        self.clock = None  # the emulator's bus (ax12_conform_bus_clock.BusClock), when there is one
        self.last_request_end = 0.0  # time.monotonic() of the last request's end

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

    def byte_s(self):
        return BITS_PER_BYTE / self.bps

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
        seconds longer). Returns a Heard. On the emulator's bus (self.clock) the timeout runs in
        simulated time: past it on the wall clock, the port is read on until the simulation has
        run as long past the request's end (a host too busy to keep the emulator in real time
        never makes a reply look missing), at most BUS_PATIENCE_S more.

        Not ax12_servo_port's transact() or ServoPort: a conformance case judges what those
        leave out, so this one times the request's end and the first byte's arrival (the
        reply's delay), keeps listening after expect_len bytes for a quiet gap (an extra or a
        duplicated reply is a finding, not noise), and allows for the longest Return Delay
        Time at the port's current bit rate."""
        data = bytes(data)
        t_send = time.monotonic()
        os.write(self.fd, data)
        self.sent += data
        sent_end = len(self.sent)
        t_end = t_send + len(data) * self.byte_s()
        self.last_request_end = t_end
        window_s = timeout + LONGEST_RDT_S + max(expect_len, P.SHORTEST) * self.byte_s()
        deadline = t_end + window_s
        if expect_len > 0 and self.clock is None:
            deadline += grace
        got = bytearray()
        t_first = None
        while True:
            now = time.monotonic()
            if len(got) >= expect_len > 0:
                wait = quiet
            else:
                wait = deadline - now
                if wait <= 0:
                    if self.clock is None or self.clock.passed(self.sent, sent_end, window_s * 1e6) \
                            or now > deadline + BUS_PATIENCE_S:
                        break
                    wait = BUS_POLL_S  # the simulation is behind the wall clock: its bus decides
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
        return Heard(bytes(got), t_end, t_first, sent_end)

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


class Device:
    """The device under test and the talk to it outside the cases: PING, READ, WRITE."""

    def __init__(self, port, ident, timeout):
        self.port = port
        self.id = ident
        self.timeout = timeout

    def ping(self, ident=None, grace=0.0):
        """The status packet (ax12_packets.Packet) of a PING; None for silence; the bytes heard
        when they are not one good status packet."""
        self.port.drain()  # nothing late from before may pass for the reply
        packet = P.instruction_packet(self.id if ident is None else ident, T.INST_PING, [])
        got = self.port.exchange(packet, P.SHORTEST, self.timeout, grace=grace).data
        p = P.parse(got)
        if p is None or not p.checksum_ok:
            return None if not got else got
        return p

    def answers_ping(self, ident):
        p = self.ping(ident)
        return p is not None and not isinstance(p, (bytes, bytearray)) and p.ident == ident

    def read(self, addr, count, ident=None):
        """The count bytes from addr, or None when no good reply of that length came."""
        ident = self.id if ident is None else ident
        self.port.drain()
        packet = P.instruction_packet(ident, T.INST_READ, [addr, count])
        got = self.port.exchange(packet, P.SHORTEST + count, self.timeout, grace=GRACE_S).data
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
        got = self.port.exchange(packet, P.SHORTEST, self.timeout + extra, grace=GRACE_S if answered else 0.0).data
        if eeprom and not got:
            time.sleep(extra)  # silent: let the EEPROM write end before the next packet
        return P.parse(got)

    def action(self, ident=None):
        ident = self.id if ident is None else ident
        self.port.drain()
        got = self.port.exchange(P.instruction_packet(ident, T.INST_ACTION, []), P.SHORTEST, self.timeout,
                                 grace=GRACE_S).data
        return P.parse(got)
