"""Dynamixel Protocol 1.0 packets, built, framed and taken apart: the one encoder, framer and
checksum of the scripts and the Python tests.

An instruction packet is FF FF ID LENGTH INSTRUCTION PARAMETERS... CHECKSUM, a status packet
FF FF ID LENGTH ERROR PARAMETERS... CHECKSUM; LENGTH counts the bytes after it. The constants
come from the firmware (ax12_table, generated from dxl_protocol.h).

Framing, the one rule every Python reader follows (the bus monitor's, model/bus/bus_monitor.h):
a packet starts at FF FF; more FF after them are header bytes too (0xFF is no servo's ID); then
ID, LENGTH (at least 2: instruction or error, checksum) and LENGTH bytes. It is framed by its
LENGTH alone: a wrong checksum still makes a packet (parse() says so). A byte where no packet
starts (no header, a LENGTH below 2) is garbage: it alone is dropped and the bytes after it are
looked at again, so a packet that begins inside garbage is found. The readers differ only in what
they do with an unfinished packet at the end of what they hold: a stream (take()) waits for more
bytes, a finished recording (cut()) calls them garbage.
"""
from collections import namedtuple

from ax12_table import HEADER_BYTE

SHORTEST = 6  # header, ID, LENGTH, instruction or error, checksum
MIN_LENGTH = 2  # the LENGTH of a packet without parameters

# code: the instruction of an instruction packet, the error byte of a status packet.
Packet = namedtuple("Packet", "ident code params checksum_ok expected_checksum")
# data[start:end] is one packet: `header` header bytes (2, more with extra FF), then ID, LENGTH.
Frame = namedtuple("Frame", "start header ident length end")
# What frame_at() says when the bytes end inside a packet (or inside what may begin one).
UNFINISHED = "unfinished"


def checksum(body):
    """The checksum of ID, LENGTH, the instruction or error byte and the parameters."""
    return ~sum(body) & 0xFF


def _packet(ident, code, params):
    body = bytes([ident, len(params) + 2, code]) + bytes(params)
    return bytes([HEADER_BYTE, HEADER_BYTE]) + body + bytes([checksum(body)])


def instruction_packet(ident, instruction, params=()):
    return _packet(ident, instruction, params)


def status_packet(ident, error, params=()):
    return _packet(ident, error, params)


def frame_at(data, start=0):
    """The packet that starts at data[start]: a Frame, UNFINISHED when data ends before its last
    byte (or inside a header that may begin one), or None when no packet starts there."""
    n = len(data)
    if start >= n or data[start] != HEADER_BYTE:
        return None
    if start + 1 >= n:
        return UNFINISHED
    if data[start + 1] != HEADER_BYTE:
        return None
    h = start + 2
    while h < n and data[h] == HEADER_BYTE:
        h += 1
    if h + 1 >= n:
        return UNFINISHED
    length = data[h + 1]
    if length < MIN_LENGTH:
        return None
    end = h + 2 + length
    if end > n:
        return UNFINISHED
    return Frame(start, h - start, data[h], length, end)


def header_ident(data):
    """The ID after a header at the start of data (FF FF, more FF), whether or not a whole packet
    follows (a malformed packet's addressee); None when data starts with no header."""
    if len(data) < 2 or data[0] != HEADER_BYTE or data[1] != HEADER_BYTE:
        return None
    h = 2
    while h < len(data) and data[h] == HEADER_BYTE:
        h += 1
    return data[h] if h < len(data) else None


def frame(data):
    """The Frame of data when data is exactly one packet, else None."""
    f = frame_at(data, 0)
    if f is None or f == UNFINISHED or f.end != len(data):
        return None
    return f


def body_of(data, f):
    """ID, LENGTH, instruction or error byte and parameters of the packet f frames in data."""
    return data[f.start + f.header:f.end - 1]


def _parse_frame(data, f):
    body = list(body_of(data, f))
    expected = checksum(body)
    return Packet(body[0], body[2], body[3:], data[f.end - 1] == expected, expected)


def parse(data):
    """The Packet data holds, exactly one whole packet, else None. A wrong checksum still
    parses: checksum_ok says so."""
    data = list(data)
    f = frame(data)
    return None if f is None else _parse_frame(data, f)


def cut(data):
    """A finished recording's bytes cut into packets and garbage, in order: [(Frame or None,
    bytes)], garbage runs (None) between the packets. An unfinished packet at the end is
    garbage."""
    data = bytes(data)
    out, garbage, i = [], b"", 0
    while i < len(data):
        f = frame_at(data, i)
        if f is None or f == UNFINISHED:
            garbage += data[i:i + 1]
            i += 1
            continue
        if garbage:
            out.append((None, garbage))
            garbage = b""
        out.append((Frame(0, f.header, f.ident, f.length, f.end - i), data[i:f.end]))
        i = f.end
    if garbage:
        out.append((None, garbage))
    return out


def split(data):
    """data cut into whole packets (each a list of byte values), or None when any byte of it is
    not part of a whole packet."""
    pieces = cut(data)
    if any(f is None for f, _ in pieces):
        return None
    return [list(chunk) for _, chunk in pieces]


def take(buffer):
    """A stream's next packet: removes and returns (as a Packet) the first whole packet at the
    start of buffer (a bytearray), garbage before it dropped; None when more bytes are needed."""
    while buffer:
        f = frame_at(buffer, 0)
        if f == UNFINISHED:
            return None
        if f is None:
            del buffer[0]
            continue
        packet = _parse_frame(bytes(buffer[:f.end]), f)
        del buffer[:f.end]
        return packet
    return None


def missing(buffer):
    """How many more bytes can complete the packet begun at the start of buffer (at least 1):
    how much a stream reader may ask for without reading past it."""
    f = frame_at(buffer, 0)
    if f == UNFINISHED and len(buffer) >= 4 and buffer[2] != HEADER_BYTE:
        return max(1, buffer[3] + 4 - len(buffer))
    return max(1, SHORTEST - len(buffer))
