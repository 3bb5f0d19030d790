"""Dynamixel Protocol 1.0 packets, built and taken apart: the one encoder and parser of the
scripts and the Python tests.

An instruction packet is FF FF ID LENGTH INSTRUCTION PARAMETERS... CHECKSUM, a status packet
FF FF ID LENGTH ERROR PARAMETERS... CHECKSUM; LENGTH counts the bytes after it. The constants
come from the firmware (ax12_table, generated from dxl_protocol.h).
"""
from collections import namedtuple

from ax12_table import HEADER_BYTE

SHORTEST = 6  # header, ID, LENGTH, instruction or error, checksum

# code: the instruction of an instruction packet, the error byte of a status packet.
Packet = namedtuple("Packet", "ident code params checksum_ok expected_checksum")


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


def parse(data):
    """The Packet data holds, exactly one whole packet (extra leading FF bytes skipped), else
    None. A wrong checksum still parses: checksum_ok says so."""
    data = list(data)
    while len(data) > SHORTEST and data[:3] == [HEADER_BYTE] * 3:
        data = data[1:]
    if len(data) < SHORTEST or data[:2] != [HEADER_BYTE] * 2 or data[3] + 4 != len(data):
        return None
    expected = checksum(data[2:-1])
    return Packet(data[2], data[4], data[5:-1], data[-1] == expected, expected)


def split(data):
    """data cut into whole packets by their LENGTH bytes (each a list of byte values), or None
    when a packet does not start with the header or data ends inside one."""
    data = list(data)
    packets = []
    while data:
        if len(data) < SHORTEST or data[:2] != [HEADER_BYTE] * 2 or len(data) < data[3] + 4:
            return None
        n = data[3] + 4
        packets.append(data[:n])
        data = data[n:]
    return packets
