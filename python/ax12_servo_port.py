# SPDX-License-Identifier: GPL-3.0-or-later
"""One servo on a serial port: an instruction packet to its ID, then its status packet.

The port is any object with pyserial's write(), read(n), reset_input_buffer() and a writable
`timeout` (seconds): a serial.Serial, or a test's stand-in. Packets are built and checked by
python/ax12_packets.py, which also frames what comes back (its one framing rule). Status packets
of other IDs (a servo answering late, or another master's exchange) are skipped.

transact() is the raw exchange under it, for the tests that look at the bytes themselves:
whatever comes back, packet or not.
"""
import time

import ax12_packets


def transact(port, request, reply_len, timeout_s=1.0):
    """Writes request to the port (its input emptied first) and returns the bytes read back:
    reply_len of them, or fewer when timeout_s seconds pass first."""
    port.reset_input_buffer()
    port.write(request)
    port.timeout = timeout_s
    return port.read(reply_len)


class NoAnswer(Exception):
    """No whole status packet from the servo within the timeout."""


class BadChecksum(Exception):
    """A status packet of the servo's ID whose checksum is wrong."""


class ServoPort:
    def __init__(self, port, ident, timeout_s):
        """ident: the servo's ID (0..253); timeout_s: how long an answer is waited for after the
        request's last byte was handed to the port."""
        self.port = port
        self.ident = ident
        self.timeout_s = timeout_s

    def exchange(self, instruction, params=()):
        """Sends instruction with params to the servo and returns its status packet
        (ax12_packets.Packet: code is the error byte). Bytes waiting before the request are
        dropped first, so a late answer to an earlier request is never taken for this one.
        Raises NoAnswer or BadChecksum."""
        self.port.reset_input_buffer()
        self.port.write(ax12_packets.instruction_packet(self.ident, instruction, params))
        return self.read_status(time.monotonic() + self.timeout_s)

    def read_status(self, deadline):
        """The next status packet of the servo's ID that arrives before deadline
        (time.monotonic()). Raises NoAnswer or BadChecksum."""
        buffer = bytearray()
        while True:
            packet = ax12_packets.take(buffer)
            if packet is not None:
                if packet.ident != self.ident:
                    continue
                if not packet.checksum_ok:
                    raise BadChecksum(f"ID {self.ident}: status packet with a wrong checksum")
                return packet
            left = deadline - time.monotonic()
            if left <= 0:
                raise NoAnswer(f"ID {self.ident}: no answer within {self.timeout_s:g} s"
                               + (f" ({len(buffer)} bytes of no whole packet)" if buffer else ""))
            self.port.timeout = min(left, 0.05)
            buffer += self.port.read(ax12_packets.missing(buffer))
