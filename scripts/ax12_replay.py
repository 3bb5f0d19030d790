#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Replays a bus log (`scripts/ax12 serve --log-bus FILE.csv`) against a Dynamixel Protocol 1.0
device on a serial port and reports where its answers differ from the recording
(`scripts/ax12 replay`; docs/emulator.md "Bus log and replay").

Every row the client sent (sender `client`: instructions, and its garbage and Protocol 2.0
bytes too) is sent again, no earlier than its recorded offset from the first client row; when
the device takes longer than the recording the schedule slips. The rows of the other senders
(the servos) between one client row and the next are the answers recorded after it. After each
packet the answers are read until the recorded time of the next client packet, and at least
until as many bytes as recorded after it have come, less those that came ahead of the recording
but its first answer at least (or --timeout has passed); a packet recorded without an answer is
listened to for at least UNANSWERED_LISTEN_S. The bytes that came are cut into packets as the
bus monitor cuts them, each taken as come after the packet sent last before its first byte.

Answers are compared in order, as one stream, not packet by packet: answers the pty handed over
in other groups than in the recording (several requests delivered at once and their answers
after the last, in the recording or in the replay, or an answer handed over late) are the same
answers. Lining up the two streams (answers alike to the byte first, nearest to the packet they
were recorded after; then by header, ID, LENGTH and error byte) keeps one answer too many or too
few from shifting the others; then each pair is compared, expected against got:

- default: the length, header, ID, LENGTH and error byte of every answer always; its data
  bytes too, except in the answers to a READ the bytes of the time-varying items (Present
  Position, Present Speed, Present Load, Present Voltage, Present Temperature, Moving), which
  no two runs of a moving servo share; the checksum when no such byte differed (else only
  that it is right when the recorded one was). Garbage is compared byte for byte.
- --strict: every byte.

A difference is reported under the packet the expected answer was recorded after (an extra
answer: the packet it came after).

Exit status: 0 every answer as recorded; 1 some differ (each difference printed: the request,
its time, expected against got); 2 a bad file (one line naming the file, the line and the
problem) or an unusable port.
"""
import argparse
import csv
import difflib
import os
import select
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "python"))

EXIT_DIFFERENT, EXIT_BAD = 1, 2
BITS_PER_BYTE = 10  # 8N1
# The columns replay reads; the log has more (docs/emulator.md).
NEEDED_COLUMNS = ("time_us", "sender", "kind", "raw")
KINDS = ("instruction", "status", "garbage", "protocol2")
CLIENT = "client"
# After the last expected answer of the last packet: how long an extra answer is waited for.
TAIL_S = 0.05
# A packet recorded without an answer is listened to at least this long before the next is
# sent, so that an answer it should not get (the difference to find) is not taken for one of the
# next packet's: an AX-12 answers within 508 us of Return Delay Time plus the wire, and a USB
# adapter's latency timer and the host's scheduling add a few milliseconds.
UNANSWERED_LISTEN_S = 0.005


class Problem(Exception):
    """A log that cannot be replayed or a port that cannot be used: a clear message, no
    traceback, exit status 2."""


def arguments(argv):
    ap = argparse.ArgumentParser(
        prog="scripts/ax12 replay",
        description="Send a bus log's client packets again to a Protocol 1.0 device and report the "
                    "answers that differ from the recording (docs/emulator.md).")
    ap.add_argument("log", metavar="FILE.csv", help="a bus log written by `scripts/ax12 serve --log-bus`")
    ap.add_argument("--port", required=True, metavar="DEV", help="the device's serial port (a pty of ax12-emu too)")
    ap.add_argument("--baud", type=int, default=1000000, metavar="B", help="bit/s (default 1000000)")
    ap.add_argument("--timeout", type=float, default=0.25, metavar="S",
                    help="how long an expected answer is waited for past the request, seconds (default 0.25)")
    ap.add_argument("--strict", action="store_true",
                    help="compare every byte, the time-varying items of READ answers included")
    ap.add_argument("--build", default=os.path.join(REPO, "build"), help=argparse.SUPPRESS)
    return ap.parse_args(argv)


def hexs(data):
    return " ".join("%02X" % b for b in data) if data else "(nothing)"


# --- the log -----------------------------------------------------------------------------------

class Row:
    def __init__(self, line, time_us, sender, kind, raw):
        self.line, self.time_us, self.sender, self.kind, self.raw = line, time_us, sender, kind, raw


def parse_hex(text, what):
    try:
        data = bytes(int(h, 16) for h in text.split())
    except ValueError:
        raise Problem("%s is not hex bytes: %r" % (what, text))
    if any(len(h) != 2 for h in text.split()):
        raise Problem("%s is not hex bytes (two digits each): %r" % (what, text))
    return data


def read_log(path):
    """The rows of a bus log, in order. Problem names the line and the problem."""
    try:
        f = open(path, newline="")
    except OSError as e:
        raise Problem("%s: %s" % (path, e.strerror or e))
    rows = []
    with f:
        reader = csv.reader(f)
        try:
            header = next(reader, None)
            if header is None:
                raise Problem("%s: empty file (no header row)" % path)
            missing = [c for c in NEEDED_COLUMNS if c not in header]
            if missing:
                raise Problem("%s:1: not a bus log: no column %s (header: %s)"
                              % (path, ", ".join(missing), ",".join(header)))
            at = {c: header.index(c) for c in NEEDED_COLUMNS}
            for fields in reader:
                line = reader.line_num
                if not fields:
                    continue
                if len(fields) != len(header):
                    raise Problem("%s:%d: %d fields, the header has %d" % (path, line, len(fields), len(header)))
                try:
                    time_us = float(fields[at["time_us"]])
                except ValueError:
                    raise Problem("%s:%d: time_us is not a number: %r" % (path, line, fields[at["time_us"]]))
                kind = fields[at["kind"]]
                if kind not in KINDS:
                    raise Problem("%s:%d: unknown kind %r (one of %s)" % (path, line, kind, ", ".join(KINDS)))
                sender = fields[at["sender"]]
                if not sender:
                    raise Problem("%s:%d: no sender" % (path, line))
                try:
                    raw = parse_hex(fields[at["raw"]], "raw")
                except Problem as e:
                    raise Problem("%s:%d: %s" % (path, line, e))
                if not raw:
                    raise Problem("%s:%d: no raw bytes" % (path, line))
                if rows and time_us < rows[-1].time_us and sender == CLIENT and rows[-1].sender == CLIENT:
                    raise Problem("%s:%d: time_us goes back (%.3f after %.3f)"
                                  % (path, line, time_us, rows[-1].time_us))
                rows.append(Row(line, time_us, sender, kind, raw))
        except csv.Error as e:
            raise Problem("%s:%d: %s" % (path, reader.line_num, e))
        except UnicodeDecodeError:
            raise Problem("%s: not a text file" % path)
    if not any(r.sender == CLIENT for r in rows):
        raise Problem("%s: no row from the client: nothing to replay" % path)
    return rows


class Exchange:
    """One client row and the answers recorded after it."""

    def __init__(self, request, answers):
        self.request = request
        self.expected = split(b"".join(a.raw for a in answers))
        self.expected_bytes = sum(len(a.raw) for a in answers)


def exchanges(rows):
    out = []
    for i, row in enumerate(rows):
        if row.sender != CLIENT:
            continue  # answers are taken with their request; any before the first are not replayed
        answers = []
        for later in rows[i + 1:]:
            if later.sender == CLIENT:
                break
            answers.append(later)
        out.append(Exchange(row, answers))
    return out


# --- packets -----------------------------------------------------------------------------------

def packets():
    """python/ax12_packets.py, the framer and checksum of every Python tool; imported once main()
    has found the generated table it needs (ax12_build.ensure)."""
    import ax12_packets
    return ax12_packets


def split(data):
    """data cut as the bus monitor cuts one sender's bytes (ax12_packets.cut): Protocol 1.0
    packets and the garbage runs between them, each a bytes object."""
    return [chunk for _, chunk in split_at(data)]


def split_at(data):
    """split(data) as (offset of the first byte, bytes) pairs."""
    out, at = [], 0
    for _, chunk in packets().cut(data):
        out.append((at, chunk))
        at += len(chunk)
    return out


def checksum_ok(packet, f):
    """Whether the last byte of the packet f frames is its checksum."""
    return packets().checksum(packets().body_of(packet, f)) == packet[-1]


def varying_addresses(T):
    """The time-varying items' addresses: what a moving servo never answers twice alike."""
    names = ("PRESENT_POSITION", "PRESENT_SPEED", "PRESENT_LOAD", "PRESENT_VOLTAGE", "PRESENT_TEMPERATURE", "MOVING")
    addrs = set()
    for item in T.ITEMS:
        if item.name in names:
            addrs.update(range(item.addr, item.addr + item.size))
    return addrs


def read_window(request, T):
    """(first address, count) when request is a whole READ packet, else None."""
    f = packets().frame(request)
    if not f:
        return None
    h = f.header
    if request[h + 2] != T.INST_READ or f.length != 4:
        return None
    return request[h + 3], request[h + 4]


def same(request, expected, got, strict, T, varying):
    """Whether got answers as expected does, by the comparison rules (module docstring)."""
    if strict or expected == got:
        return expected == got
    fe, fg = packets().frame(expected), packets().frame(got)
    if not fe or not fg or len(expected) != len(got) or fe.header != fg.header:
        return False
    h = fe.header
    if expected[:h + 3] != got[:h + 3]:  # header, ID, LENGTH, error byte
        return False
    window = read_window(request, T)
    skipped = False
    for j in range(h + 3, len(expected) - 1):
        if expected[j] == got[j]:
            continue
        if window and window[0] + (j - h - 3) in varying:
            skipped = True
            continue
        return False
    if skipped:
        return checksum_ok(got, fg) or not checksum_ok(expected, fe)
    return expected[-1] == got[-1]


# --- the port ----------------------------------------------------------------------------------

class Port:
    def __init__(self, path, bps):
        import serial  # pyserial, from the project's venv (scripts/setup)
        if not os.path.exists(path):
            raise Problem("no such port: %s" % path)
        try:
            self.s = serial.Serial(path, bps, timeout=0, write_timeout=2)
        except (serial.SerialException, OSError, ValueError) as e:
            raise Problem("cannot open %s: %s" % (path, e))
        self.fd = self.s.fileno()
        self.bps = bps

    def read_until(self, deadline, got, enough=None):
        """Appends to got what comes until deadline, or until enough() is true."""
        while True:
            if enough and enough():
                return
            wait = deadline - time.monotonic()
            if wait <= 0:
                return
            r, _, _ = select.select([self.fd], [], [], wait)
            if r:
                chunk = os.read(self.fd, 4096)
                if chunk:
                    got.extend(chunk)

    def close(self):
        self.s.close()


# --- the replay --------------------------------------------------------------------------------

def describe(row, T):
    packet = row.raw
    f = packets().frame(packet)
    if row.kind != "instruction" or not f:
        return row.kind
    h, ident = f.header, f.ident
    names = {T.INST_PING: "PING", T.INST_READ: "READ", T.INST_WRITE: "WRITE", T.INST_REG_WRITE: "REG_WRITE",
             T.INST_ACTION: "ACTION", T.INST_RESET: "RESET", T.INST_SYNC_WRITE: "SYNC_WRITE"}
    name = names.get(packet[h + 2], "instruction 0x%02X" % packet[h + 2])
    bad = "" if checksum_ok(packet, f) else ", bad checksum"
    return "%s ID %d%s" % (name, ident, bad)


def replay(args, T):
    rows = read_log(args.log)
    exs = exchanges(rows)
    port = Port(args.port, args.baud)
    varying = set() if args.strict else varying_addresses(T)
    rule = ("every byte (--strict)" if args.strict else
            "all but the time-varying items of READ answers (addresses %s)" % ranges(sorted(varying)))
    print("ax12 replay: %s -> %s at %d bit/s: %d client packets, %d answers recorded; compared: %s"
          % (args.log, args.port, args.baud, len(exs), sum(len(e.expected) for e in exs), rule))
    byte_s = BITS_PER_BYTE / args.baud
    sent_times = []
    differences = 0
    differing = set()  # exchanges with a difference
    t0_rec = exs[0].request.time_us
    port.read_until(time.monotonic() + 0.01, bytearray())  # what the device sent before: not an answer
    t0 = time.monotonic()

    def report(k, sent_at, lines):
        nonlocal differences
        ex = exs[k]
        if k not in differing:
            print("packet %d (line %d) sent at +%.3f ms (recorded +%.3f ms): %s [%s]"
                  % (k + 1, ex.request.line, (sent_at - t0) * 1e3, (ex.request.time_us - t0_rec) / 1e3,
                     describe(ex.request, T), hexs(ex.request.raw)))
        differing.add(k)
        differences += len(lines)
        for line in lines:
            print("  " + line)

    stream = bytearray()   # every byte the device sent, in order
    window_at = []         # window_at[k]: where in stream the bytes after packet k begin
    expected_before = 0    # bytes recorded after the packets before this one
    try:
        for k, ex in enumerate(exs):
            # The previous window read up to this packet's time (or past it): nothing is pending.
            sent_at = time.monotonic()
            os.write(port.fd, ex.request.raw)
            sent_times.append(sent_at)
            window_at.append(len(stream))
            wire_end = sent_at + len(ex.request.raw) * byte_s
            need = ex.expected_bytes
            if need:
                # This packet's answers, less what came ahead of the recording (a pty that handed
                # over answers to requests it had delivered at once), but its first answer at
                # least.
                ahead = max(0, len(stream) - expected_before)
                wanted = max(need - ahead, len(ex.expected[0]))
                start = len(stream)
                port.read_until(wire_end + args.timeout + need * byte_s, stream, lambda: len(stream) - start >= wanted)
            expected_before += need
            if k + 1 < len(exs):
                next_at = t0 + (exs[k + 1].request.time_us - t0_rec) / 1e6
                if not need:
                    next_at = max(next_at, wire_end + UNANSWERED_LISTEN_S)
                port.read_until(next_at, stream)
            else:
                port.read_until(time.monotonic() + TAIL_S, stream)
    finally:
        port.close()
    for k, lines in compare_all(exs, answers_by_window(stream, window_at), args.strict, T, varying):
        report(k, sent_times[k], lines)
    if differences:
        print("result: DIFFERENT: %d difference%s in %d of %d exchanges"
              % (differences, "" if differences == 1 else "s", len(differing), len(exs)))
        return EXIT_DIFFERENT
    print("result: SAME: every answer as recorded (%d exchanges)" % len(exs))
    return 0


def answers_by_window(stream, window_at):
    """The packets of stream (split as the monitor cuts them), each in the list of the window
    its first byte came in: window k from window_at[k] to the next."""
    windows = [[] for _ in window_at]
    k = 0
    for offset, packet in split_at(bytes(stream)):
        while k + 1 < len(window_at) and window_at[k + 1] <= offset:
            k += 1
        windows[k].append(packet)
    return windows


def compare_all(exs, got_by_window, strict, T, varying):
    """[(exchange index, lines)] of every exchange with a difference, the answers of the whole
    replay compared as one stream (compare_stream): an expected answer reported where it was
    recorded, an extra one where it came."""
    expected = [(k, i, packet) for k, ex in enumerate(exs) for i, packet in enumerate(ex.expected)]
    got = [(k, j, packet) for k, packets in enumerate(got_by_window) for j, packet in enumerate(packets)]
    found = {}
    for k, line in compare_stream(exs, expected, got, strict, T, varying):
        found.setdefault(k, []).append(line)
    return sorted(found.items())


def shape(packet):
    """What two answers must share to be taken for the same answer, one maybe changed: a
    packet's header, ID, LENGTH and error byte; garbage whole."""
    f = packets().frame(packet)
    return packet if not f else packet[:f.header + 3]


def compare(ex, answers, strict, T, varying):
    """Lines naming each difference between the answers expected after one exchange and got."""
    return [line for _, line in compare_stream([ex], [(0, i, e) for i, e in enumerate(ex.expected)],
                                               [(0, j, g) for j, g in enumerate(answers)], strict, T, varying)]


# Lining up the answers (compare_stream): a pair alike to the byte scores ALIKE, less
# FAR_PER_PACKET for each packet between the one it was recorded after and the one it came
# after; a pair of one shape (header, ID, LENGTH, error byte) scores SHAPED, any other pair
# OTHER (one answer in place of another: "different"); an answer left alone (missing or extra)
# nothing. The n-th answer expected is paired with one at most SHIFT_MAX places from the n-th
# got (answers missing or extra, net); beyond, they are lined up by shape alone (difflib).
ALIKE, SHAPED, OTHER, FAR_PER_PACKET = 2.0, 1.0, 0.25, 1e-3
SHIFT_MAX = 40


def aligned(expected, got):
    """[(i, j)] pairs of expected[i] and got[j] (each (exchange, number, bytes)), in order, that
    line up best: the others are missing (expected) or extra (got)."""
    n, m = len(expected), len(got)
    band = SHIFT_MAX + abs(n - m)
    if band > 4 * SHIFT_MAX:
        matcher = difflib.SequenceMatcher(a=[shape(e) for _, _, e in expected], b=[shape(g) for _, _, g in got],
                                          autojunk=False)
        return [(i1 + d, j1 + d) for tag, i1, i2, j1, j2 in matcher.get_opcodes() if tag in ("equal", "replace")
                for d in range(min(i2 - i1, j2 - j1))]

    def score(i, j):
        (ke, _, e), (kg, _, g) = expected[i], got[j]
        if e == g:
            return ALIKE - FAR_PER_PACKET * abs(ke - kg)
        return SHAPED if shape(e) == shape(g) else OTHER

    lowest = float("-inf")
    best = {}  # (i, j) -> the best score of expected[i:] against got[j:], within the band

    def at(i, j):
        if i == n or j == m:
            return 0.0
        return best.get((i, j), lowest)

    for i in range(n - 1, -1, -1):
        for j in range(min(m - 1, i + band), max(0, i - band) - 1, -1):
            best[(i, j)] = max(at(i + 1, j), at(i, j + 1), score(i, j) + at(i + 1, j + 1))
    pairs, i, j = [], 0, 0
    while i < n and j < m:
        here = at(i, j)
        if here == score(i, j) + at(i + 1, j + 1):
            pairs.append((i, j))
            i, j = i + 1, j + 1
        elif here == at(i + 1, j):
            i += 1
        else:
            j += 1
    return pairs


def compare_stream(exs, expected, got, strict, T, varying):
    """[(exchange index, line)] naming each difference between the answers expected and got,
    each given as (exchange index, its number there, bytes) in order. The two lists are lined
    up first (aligned), so an answer in excess or missing among others is reported as such and
    the others are still compared with their counterparts; a pair is compared by the rule of
    the request the expected answer was recorded after."""
    out = []
    pairs = aligned(expected, got)
    paired_e, paired_g = {i for i, _ in pairs}, {j for _, j in pairs}
    for i, j in pairs:
        (k, n, e), g = expected[i], got[j][2]
        if not same(exs[k].request.raw, e, g, strict, T, varying):
            out.append((k, "answer %d: different: expected %s, got %s" % (n + 1, hexs(e), hexs(g))))
    for i, (k, n, e) in enumerate(expected):
        if i not in paired_e:
            out.append((k, "answer %d: missing: expected %s, got nothing" % (n + 1, hexs(e))))
    for j, (k, n, g) in enumerate(got):
        if j not in paired_g:
            out.append((k, "answer %d: extra: expected nothing, got %s" % (n + 1, hexs(g))))
    return out


def ranges(values):
    out, start = [], None
    for i, v in enumerate(values):
        if start is None:
            start = v
        if i + 1 == len(values) or values[i + 1] != v + 1:
            out.append(str(start) if start == v else "%d..%d" % (start, v))
            start = None
    return ", ".join(out)


def main(argv=None):
    args = arguments(sys.argv[1:] if argv is None else argv)
    import ax12_build  # noqa: E402
    ax12_build.ensure(args.build)
    import ax12_table as T  # noqa: E402
    try:
        return replay(args, T)
    except Problem as e:
        print("ax12 replay: %s" % e, file=sys.stderr)
        return EXIT_BAD
    except KeyboardInterrupt:
        print("ax12 replay: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
