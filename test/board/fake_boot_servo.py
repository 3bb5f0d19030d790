# SPDX-License-Identifier: GPL-3.0-or-later
"""A servo without a simulator, for the tests of `scripts/ax12 flash`: a stand-in for the
serial port (pyserial's write, read, reset_input_buffer, timeout, close) behind which one
servo answers as docs/bootloader.md says its bootloader does, or as its application does
(PING, READ DATA of the Model Number, 0x0A "BOOT"; anything else an Instruction Error).

Faults, to see the tool's retries and messages: fault(instruction, kind, times) makes the next
`times` requests of that instruction (from its `after`-th on) never reach the servo ("lost"),
lose their answer ("drop"), get an answer with a wrong checksum ("checksum"), or an error byte
(an int); `silent` answers nothing at all; `status_return_level` 0 makes the application
answer PING only; `other_id_first` sends a status packet of another ID before every answer;
`read_flip` flips one byte of the READ answers at that flash address.

Every request is recorded in `requests` as (instruction, params).
"""
import time

import ax12_packets
from ax12_table import INST_BOOTLOADER as BOOT, INST_PING as PING, INST_READ as READ_DATA

import ax12_app_image

INFO, BEGIN, PAGE, END, READ, GO = 0x20, 0x21, 0x22, 0x23, 0x24, 0x25  # the bootloader's (docs/bootloader.md)
SIGNATURES = {"atmega328p": b"\x1e\x95\x0f", "atmega88": b"\x1e\x93\x0a"}


class FakeBootServo:
    def __init__(self, ident=2, mcu="atmega328p", mode="boot", app_area=0x7800, page=128, knows_boot=True):
        self.ident, self.mcu, self.mode = ident, mcu, mode
        self.app_area, self.page_bytes = app_area, page
        self.flash = bytearray(b"\xff" * app_area)
        self.knows_boot = knows_boot
        self.begun = None
        self.silent = False
        self.other_id_first = False
        self.stays_after_go = False
        self.status_return_level = 2
        self.read_flip = None
        self.faults = []  # [instruction, kind, after, times]
        self.requests = []
        self.received = bytearray()
        self.timeout = 0.05
        self._out = bytearray()
        self._in = bytearray()
        self.closed = False

    # --- faults ---------------------------------------------------------------------------
    def fault(self, instruction, kind, times=1, after=0):
        self.faults.append([instruction, kind, after, times])

    def _fault_for(self, instruction):
        for entry in self.faults:
            if entry[0] != instruction or entry[3] == 0:
                continue
            if entry[2] > 0:
                entry[2] -= 1
                return None
            entry[3] -= 1
            return entry[1]
        return None

    # --- the port -------------------------------------------------------------------------
    def write(self, data):
        self.received += data
        self._in += data
        while True:
            packet = ax12_packets.take(self._in)
            if packet is None:
                break
            if packet.checksum_ok and packet.ident == self.ident:
                self.requests.append((packet.code, bytes(packet.params)))
                self._fault = self._fault_for(packet.code)
                if self._fault != "lost":
                    self._answer(packet.code, bytes(packet.params))
        return len(data)

    def read(self, count):
        if not self._out:
            time.sleep(self.timeout or 0)
        data = bytes(self._out[:count])
        del self._out[:count]
        return data

    def reset_input_buffer(self):
        self._out.clear()

    def close(self):
        self.closed = True

    # --- the servo ------------------------------------------------------------------------
    def _send(self, error, params=b""):
        if self.silent:
            return
        fault = self._fault
        if fault == "drop":
            return
        if isinstance(fault, int):
            error = fault
        if self.other_id_first:
            self._out += ax12_packets.status_packet(self.ident + 1, 0, b"\x00")
        packet = bytearray(ax12_packets.status_packet(self.ident, error, params))
        if fault == "checksum":
            packet[-1] ^= 0xFF
        self._out += packet

    def _answer(self, instruction, params):
        if self.mode == "app":
            self._answer_as_application(instruction, params)
        else:
            self._answer_as_bootloader(instruction, params)

    def _answer_as_application(self, instruction, params):
        if self.status_return_level == 0 and instruction != PING:
            if instruction == BOOT and params == b"BOOT" and self.knows_boot:
                self.mode = "boot"
            return
        if instruction == PING:
            self._send(0)
        elif instruction == READ_DATA and params == b"\x00\x03":
            self._send(0, bytes([12, 0, 1]))
        elif instruction == BOOT and params == b"BOOT" and self.knows_boot:
            self._send(0)
            self.mode = "boot"
        else:
            self._send(0x40)

    def _record_valid(self):
        record = self.flash[self.app_area - self.page_bytes:][:8]
        if record[:4] != b"AXAP":
            return False
        length = int.from_bytes(record[4:6], "little")
        crc = int.from_bytes(record[6:8], "little")
        return 0 < length <= self.app_area - self.page_bytes and ax12_app_image.crc16(self.flash[:length]) == crc

    def _answer_as_bootloader(self, instruction, params):
        record_at = self.app_area - self.page_bytes
        u16 = lambda at: int.from_bytes(params[at:at + 2], "little")  # noqa: E731
        if instruction == PING and not params:
            self._send(0)
        elif instruction == INFO and not params:
            self._send(0, b"AXBL" + bytes([1]) + SIGNATURES[self.mcu] + self.page_bytes.to_bytes(2, "little")
                       + self.app_area.to_bytes(2, "little") + bytes([int(self._record_valid())]))
        elif instruction == BEGIN and len(params) == 4:
            if not 0 < u16(0) <= record_at:
                return self._send(0x08)
            self.begun = (u16(0), u16(2))
            self.flash[record_at:] = b"\xff" * self.page_bytes
            self._send(0)
        elif instruction == PAGE and len(params) == 4 + self.page_bytes:
            address, data = u16(0), params[4:]
            if self.begun is None or address % self.page_bytes or address >= record_at:
                return self._send(0x08)
            if ax12_app_image.crc16(data) != u16(2):
                return self._send(0x10)
            self.flash[address:address + self.page_bytes] = data
            self._send(0)
        elif instruction == END and not params:
            if self.begun is None:
                return self._send(0x08)
            length, crc = self.begun
            if ax12_app_image.crc16(self.flash[:length]) != crc:
                return self._send(0x10)
            self.flash[record_at:record_at + 8] = b"AXAP" + length.to_bytes(2, "little") + crc.to_bytes(2, "little")
            self._send(0)
        elif instruction == READ and len(params) == 2:
            address = u16(0)
            if address % self.page_bytes or address >= self.app_area:
                return self._send(0x08)
            data = bytearray(self.flash[address:address + self.page_bytes])
            if self.read_flip is not None and address <= self.read_flip < address + self.page_bytes:
                data[self.read_flip - address] ^= 0x01
            self._send(0, bytes(data))
        elif instruction == GO and not params:
            if not self._record_valid():
                return self._send(0x10)
            self._send(0)
            if not self.stays_after_go:
                self.mode = "app"
        elif instruction == BOOT and params == b"BOOT":
            self._send(0)
        else:
            self._send(0x40)
