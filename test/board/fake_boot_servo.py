# SPDX-License-Identifier: GPL-3.0-or-later
"""A servo without a simulator, for the tests of `scripts/ax12 flash`: a stand-in for the
serial port (pyserial's write, read, reset_input_buffer, timeout, close) behind which one
servo answers as docs/bootloader.md says its bootloader does, or as its application does
(PING, READ DATA of the Model Number, 0x0A "BOOT"; anything else an Instruction Error).

Faults, to see the tool's retries and messages: fault(instruction, kind, times) makes the next
`times` requests of that instruction (from its `after`-th on) never reach the servo ("lost"),
never reach it while the answer to the request before comes again ("stale": a late answer to
an earlier request), lose their answer ("drop"), get an answer with a wrong checksum
("checksum"), or an error byte (an int); `silent` answers nothing at all; `status_return_level` 0 makes the application
answer PING only; `other_id_first` sends a status packet of another ID before every answer;
`read_flip` flips one byte of the READ answers at that flash address; `boot_busy` makes the
application answer that many BOOT requests without entering (a store of its settings under
way).

Every request is recorded in `requests` as (instruction, params).
"""
import time

import ax12_packets
from ax12_table import INST_BOOTLOADER as BOOT, INST_PING as PING, INST_READ as READ_DATA

import ax12_app_image
import ax12_fuses

INFO, PAGE, READ, GO = 0x20, 0x22, 0x24, 0x25  # the bootloader's (docs/bootloader.md)


class FakeBootServo:
    def __init__(self, ident=2, mcu="atmega328p", mode="boot", knows_boot=True):
        part = ax12_fuses.MCUS[mcu]
        self.ident, self.mcu, self.mode = ident, mcu, mode
        self.app_area, self.page_bytes, self.signature = part.boot_start, part.page_bytes, part.signature
        self.flash = bytearray(b"\xff" * self.app_area)
        self.knows_boot = knows_boot
        self.boot_busy = 0
        self.silent = False
        self.other_id_first = False
        self.stays_after_go = False
        self.status_return_level = 2
        self.read_flip = None
        self.faults = []  # [instruction, kind, after, times]
        self.requests = []
        self.received = bytearray()
        self.last_answer = b""
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
                if self._fault == "stale":
                    self._out += self.last_answer
                elif self._fault != "lost":
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
        self.last_answer = bytes(packet)

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
            if self.boot_busy:
                self.boot_busy -= 1
            else:
                self.mode = "boot"
        else:
            self._send(0x40)

    def _record_valid(self):
        record = self.flash[self.app_area - 4:]
        last = int.from_bytes(record[:2], "little")
        return last < self.app_area and ax12_app_image.check_value(self.flash[:last + 1]) == \
            int.from_bytes(record[2:], "little")

    def _page_of(self, params):
        """The first byte of the page that holds the address in params, None outside the
        application area."""
        address = int.from_bytes(params[:2], "little") & ~(self.page_bytes - 1)
        return address if address < self.app_area else None

    def _answer_as_bootloader(self, instruction, params):
        if instruction in (PING, BOOT):
            self._send(0)
        elif instruction == INFO:
            self._send(0, bytes([2]) + self.signature)
        elif instruction == PAGE:  # its answer carries the address back
            address = self._page_of(params)
            if len(params) != 2 + self.page_bytes:
                return self._send(0x40, params[:2])
            if address is None:
                return self._send(0x08, params[:2])
            self.flash[address:address + self.page_bytes] = params[2:]
            self._send(0, params[:2])
        elif instruction == READ and len(params) == 2:
            address = self._page_of(params)
            if address is None:
                return self._send(0x08)
            data = bytearray(self.flash[address:address + self.page_bytes])
            if self.read_flip is not None and address <= self.read_flip < address + self.page_bytes:
                data[self.read_flip - address] ^= 0x01
            self._send(0, bytes(data))
        elif instruction == GO:
            self._send(0)
            if self._record_valid() and not self.stays_after_go:
                self.mode = "app"
        else:
            self._send(0x40)
