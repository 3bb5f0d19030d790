# SPDX-License-Identifier: GPL-3.0-or-later
"""A programmer without hardware, for tests: an STK500 version 1 protocol programmer (as
avrdude's `-c stk500v1` speaks it, Atmel's AVR061) behind a pseudo-terminal, with an ISP
target of its own: flash, EEPROM, signature and fuse bytes in memory. Written from the
protocol's description; it answers what avrdude 7.1 sends to read, erase, write and verify
flash and fuses, and records the fuse writes and the flash it was given.
"""

import os
import select
import threading
import tty

INSYNC, OK, EOP = 0x14, 0x10, 0x20

SIGNATURES = {"atmega88": (0x1E, 0x93, 0x0A), "atmega328p": (0x1E, 0x95, 0x0F)}
FLASH_BYTES = {"atmega88": 8192, "atmega328p": 32768}


class FakeStk500:
    def __init__(self, mcu):
        self.signature = SIGNATURES[mcu]
        self.flash = bytearray(b"\xff" * FLASH_BYTES[mcu])
        self.eeprom = bytearray(b"\xff" * 512)
        # Factory fuses (1 MHz internal RC, divided by 8).
        self.fuses = {"lfuse": 0x62, "hfuse": 0xDF, "efuse": 0xF9 if mcu == "atmega88" else 0xFF}
        self.fuse_writes = []
        self.erased = 0
        self.address = 0  # word address
        self.master, slave = os.openpty()
        tty.setraw(self.master)
        self.port = os.ttyname(slave)
        self._slave = slave
        self._stop = False
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def close(self):
        self._stop = True
        self._thread.join(timeout=2)
        os.close(self.master)
        os.close(self._slave)

    def _read(self, count):
        data = b""
        while len(data) < count:
            if self._stop:
                raise EOFError
            ready, _, _ = select.select([self.master], [], [], 0.1)
            if ready:
                try:
                    chunk = os.read(self.master, count - len(data))
                except OSError:
                    raise EOFError
                data += chunk
        return data

    def _reply(self, payload=b""):
        os.write(self.master, bytes([INSYNC]) + bytes(payload) + bytes([OK]))

    def _universal(self, a, b, c, d):
        """One 4-byte ISP instruction of the target; returns its 4th byte."""
        if a == 0xAC and b == 0x80:
            self.flash[:] = b"\xff" * len(self.flash)
            self.erased += 1
            if self.fuses["hfuse"] & 0x08:  # EESAVE unprogrammed: the EEPROM is erased too
                self.eeprom[:] = b"\xff" * len(self.eeprom)
            return 0
        writes = {(0xAC, 0xA0): "lfuse", (0xAC, 0xA8): "hfuse", (0xAC, 0xA4): "efuse"}
        if (a, b) in writes:
            if writes[(a, b)] == "efuse":
                d |= 0xF8  # bits 7..3 of both parts' extended byte are unused: they read 1
            self.fuses[writes[(a, b)]] = d
            self.fuse_writes.append((writes[(a, b)], d))
            return d
        reads = {(0x50, 0x00): "lfuse", (0x58, 0x08): "hfuse", (0x50, 0x08): "efuse"}
        if (a, b) in reads:
            return self.fuses[reads[(a, b)]]
        if a == 0x58 and b == 0x00:
            return 0xFF  # lock bits
        if a == 0x30:
            return self.signature[c & 3] if (c & 3) < 3 else 0
        if a == 0x38:
            return 0x80  # calibration
        return 0

    def _serve(self):
        try:
            while not self._stop:
                command = self._read(1)[0]
                if command in (0x30, 0x50, 0x51, 0x52):  # sync, enter/leave progmode, chip erase
                    self._read(1)
                    if command == 0x52:
                        self._universal(0xAC, 0x80, 0, 0)
                    self._reply()
                elif command == 0x31:  # sign-on
                    self._read(1)
                    self._reply(b"AVR STK")
                elif command == 0x41:  # get parameter
                    parameter = self._read(2)[0]
                    values = {0x80: 2, 0x81: 1, 0x82: 18, 0x84: 50, 0x85: 50, 0x86: 0, 0x87: 1, 0x89: 1, 0x98: 0xFF}
                    self._reply([values.get(parameter, 0)])
                elif command == 0x40:  # set parameter
                    self._read(3)
                    self._reply()
                elif command == 0x42:  # set device: 20 parameters
                    self._read(21)
                    self._reply()
                elif command == 0x45:  # set device, extended: a count, count - 1 parameters
                    count = self._read(1)[0]
                    self._read(count - 1 + 1)
                    self._reply()
                elif command == 0x75:  # read signature
                    self._read(1)
                    self._reply(self.signature)
                elif command == 0x56:  # universal
                    a, b, c, d, _ = self._read(5)
                    self._reply([self._universal(a, b, c, d)])
                elif command == 0x55:  # load address (words for flash, bytes for EEPROM)
                    low, high, _ = self._read(3)
                    self.address = low | high << 8
                elif command == 0x64:  # program page
                    high, low, memory = self._read(3)
                    size = high << 8 | low
                    data = self._read(size)
                    self._read(1)
                    if memory == ord("F"):
                        start = self.address * 2
                        self.flash[start:start + size] = data
                    else:
                        self.eeprom[self.address:self.address + size] = data
                    self._reply()
                    continue
                elif command == 0x74:  # read page
                    high, low, memory, _ = self._read(4)
                    size = high << 8 | low
                    if memory == ord("F"):
                        start = self.address * 2
                        self._reply(self.flash[start:start + size])
                    else:
                        self._reply(self.eeprom[self.address:self.address + size])
                    continue
                else:  # unknown: say so, as the protocol does
                    os.write(self.master, bytes([0x12]))
                    continue
                if command == 0x55:
                    self._reply()
        except EOFError:
            pass
