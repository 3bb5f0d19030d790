# SPDX-License-Identifier: GPL-3.0-or-later
"""python/ax12_packets.py: the one framer and checksum of the Python tools (its docstring states
the rule). A stream (take) and a finished recording (cut) frame the same bytes the same way
and differ only at an unfinished end."""
import random

import ax12_packets as P
import ax12_table as T

STATUS = P.status_packet(1, 0)
PING = P.instruction_packet(1, T.INST_PING)


def test_checksum_and_builders_match_the_manual():
    # the manual's example: PING to ID 1 is FF FF 01 02 01 FB; its reply FF FF 01 02 00 FC
    assert PING == bytes([0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB])
    assert STATUS == bytes([0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC])
    assert P.checksum([0x01, 0x04, 0x02, 0x2B, 0x01]) == 0xCC


def test_parse_takes_one_whole_packet_and_reports_a_wrong_checksum():
    p = P.parse(P.instruction_packet(7, T.INST_READ, [0x2B, 1]))
    assert (p.ident, p.code, p.params, p.checksum_ok) == (7, T.INST_READ, [0x2B, 1], True)
    bad = bytearray(STATUS)
    bad[-1] ^= 1
    assert P.parse(bad).checksum_ok is False and P.parse(bad).expected_checksum == STATUS[-1]
    assert P.parse(b"\xff" + STATUS).ident == 1  # an extra header byte
    assert P.parse(STATUS + b"\x00") is None and P.parse(STATUS[:-1]) is None
    assert P.parse(b"\xff\xff\x01\x01\x00") is None  # LENGTH 1: no packet


def test_cut_finds_packets_among_garbage_as_the_monitor_does():
    def chunks(data):
        return [c for _, c in P.cut(data)]
    assert chunks(b"\x00" + STATUS + b"\x12\xff") == [b"\x00", STATUS, b"\x12\xff"]
    assert chunks(b"\xff" + STATUS) == [b"\xff" + STATUS]
    assert chunks(b"\xff\xff\x01\x01" + STATUS) == [b"\xff\xff\x01\x01", STATUS]  # LENGTH 1: no packet
    assert chunks(STATUS[:-1]) == [STATUS[:-1]]  # cut short: garbage
    # a packet with a wrong checksum is framed by its LENGTH all the same
    bad = bytes(STATUS[:-1]) + bytes([STATUS[-1] ^ 0xFF])
    assert chunks(bad + PING) == [bad, PING]
    assert [f is not None for f, _ in P.cut(b"\x00" + STATUS)] == [False, True]


def test_split_is_whole_packets_or_nothing():
    assert P.split(STATUS + PING) == [list(STATUS), list(PING)]
    assert P.split(STATUS + b"\x00") is None
    assert P.split(b"") == []


def test_a_stream_frames_every_piece_as_the_recording_does():
    """Bytes fed in random pieces to take() give the packets cut() finds in the whole, and take()
    never asks (missing) for a byte past the packet it reads."""
    rng = random.Random(31)
    for _ in range(300):
        data = bytearray()
        for _ in range(rng.randint(1, 6)):
            kind = rng.random()
            if kind < 0.5:
                params = bytes(rng.randrange(256) for _ in range(rng.randint(0, 4)))
                packet = bytearray(P.status_packet(rng.randint(0, 253), rng.randrange(256), params))
                if rng.random() < 0.2:
                    packet[-1] ^= 0x55
                data += packet
            elif kind < 0.8:
                data += bytes(rng.choice([0x00, 0xFF, 0x01, 0x12, rng.randrange(256)]) for _ in range(rng.randint(1, 4)))
            else:
                data += b"\xff" * rng.randint(1, 3)
        expected = [P.parse(c) for f, c in P.cut(data) if f is not None]
        buffer, got, i = bytearray(), [], 0
        while i < len(data):
            n = min(P.missing(buffer), rng.randint(1, 8))
            buffer += data[i:i + n]
            i += n
            while True:
                packet = P.take(buffer)
                if packet is None:
                    break
                got.append(packet)
        # the stream holds back what may still become a packet: the recording calls it garbage
        assert got == expected[:len(got)]
        rest = [P.parse(c) for f, c in P.cut(buffer) if f is not None]
        assert got + rest == expected


def test_missing_never_reads_past_a_packet():
    buffer = bytearray(P.instruction_packet(1, T.INST_WRITE, [25, 1])[:4])
    assert P.missing(buffer) == 4  # FF FF 01 04: the four bytes LENGTH counts are still to come
    assert P.missing(bytearray()) == P.SHORTEST
