# SPDX-License-Identifier: GPL-3.0-or-later
"""The host side of the bootloader's protocol (docs/bootloader.md "Packets"), over one servo's
ServoPort (python/ax12_servo_port.py): its instructions, the INFO answer, and the
application's way in (instruction 0x0A "BOOT").

Every method sends one request (again on a lost or garbled answer, up to `retries` more times,
where repeating it is harmless) and returns the answer's parameters, or raises BootError with a
message naming the servo and the step.
"""
import time
from collections import namedtuple

from ax12_servo_port import BadChecksum, NoAnswer
from ax12_table import (BOOTLOADER_KEY_0, BOOTLOADER_KEY_1, BOOTLOADER_KEY_2, BOOTLOADER_KEY_3, BY_ADDR,
                        FIRMWARE_VERSION, INST_BOOTLOADER as BOOT, INST_PING as PING, INST_READ as READ_DATA,
                        MODEL_NUMBER)

INFO, PAGE, READ, GO = 0x20, 0x22, 0x24, 0x25
BOOT_PARAMS = bytes([BOOTLOADER_KEY_0, BOOTLOADER_KEY_1, BOOTLOADER_KEY_2, BOOTLOADER_KEY_3])  # "BOOT"
# The application's Model Number (2 bytes) and Firmware Version, read at once.
IDENTITY_ADDRESS = MODEL_NUMBER
IDENTITY_BYTES = FIRMWARE_VERSION + BY_ADDR[FIRMWARE_VERSION].size - MODEL_NUMBER
# The bootloader's version whose layout and packets these are (docs/bootloader.md).
VERSION = 2

ERR_INSTRUCTION, ERR_RANGE, ERR_READ_BACK = 0x40, 0x08, 0x20
ERROR_NAMES = {ERR_INSTRUCTION: "unknown instruction or wrong length",
               ERR_RANGE: "address outside the application area",
               ERR_READ_BACK: "the page did not read back as sent"}

# Sent before a request goes again after a lost answer: no header in them, and one more than a
# packet's longest rest (LENGTH 255), so they end any packet the bootloader's framing took up
# from bytes of a cut one, whether or not its 100 ms gap has passed in the servo's time
# (docs/bootloader.md "Packets").
FLUSH = bytes(256)

# The INFO answer (docs/bootloader.md): the bootloader's version and the MCU's signature.
BootInfo = namedtuple("BootInfo", "version signature")


class BootError(Exception):
    """A step that failed: the servo did not answer, or answered with an error."""


def error_text(error):
    return ", ".join(name for bit, name in ERROR_NAMES.items() if error & bit) or f"error bits 0x{error:02X}"


def parse_info(answer):
    """The BootInfo of an answer to INFO, or None when it is not a bootloader's (an
    application answers Instruction Error with no parameters)."""
    if answer is None or answer.code or len(answer.params) != 4:
        return None
    return BootInfo(answer.params[0], bytes(answer.params[1:4]))


def u16(value):
    return list(value.to_bytes(2, "little"))


class BootClient:
    def __init__(self, servo_port, retries):
        self.servo = servo_port
        self.retries = retries

    @property
    def ident(self):
        return self.servo.ident

    def _exchange(self, instruction, params, echo):
        """The servo's answer to one request; with echo, an answer whose parameters are not
        echo is a late one to an earlier request (sent again after a timeout), and the next
        one is waited for."""
        answer = self.servo.exchange(instruction, params)
        deadline = time.monotonic() + self.servo.timeout_s
        while echo is not None and bytes(answer.params) != echo:
            answer = self.servo.read_status(deadline)
        return answer

    def ask(self, instruction, params=(), what="", retry_errors=0, attempts=None, echo=None):
        """The answer (ax12_packets.Packet) to instruction, sent again after a timeout, a bad
        checksum or an error bit among retry_errors, at most attempts times in all (default
        retries + 1). Any other error bit raises BootError at once. echo: the parameters the
        answer must carry (others are late answers, skipped)."""
        attempts = self.retries + 1 if attempts is None else attempts
        problem = None
        for attempt in range(attempts):
            if attempt:
                self.servo.port.write(FLUSH)
            try:
                answer = self._exchange(instruction, params, echo)
            except (NoAnswer, BadChecksum) as error:
                problem = str(error)
                continue
            if answer.code & retry_errors:
                problem = f"ID {self.ident}: {error_text(answer.code)}"
                continue
            if answer.code:
                raise BootError(f"{what}: servo {self.ident} answered with {error_text(answer.code)}")
            return answer
        raise BootError(f"{what}: {problem} ({attempts} attempt{'s' if attempts > 1 else ''})")

    def _first_answer(self, instruction, attempts):
        """The first answer to instruction in up to `attempts` tries (any error byte), or None."""
        for _ in range(attempts):
            try:
                return self.servo.exchange(instruction)
            except (NoAnswer, BadChecksum):
                continue
        return None

    def info(self, attempts=1):
        """The raw answer to INFO (any error byte), or None when nothing answered."""
        return self._first_answer(INFO, attempts)

    def ping(self, attempts=1):
        """The answer to PING, or None."""
        return self._first_answer(PING, attempts)

    def application_identity(self):
        """The application's answer to READ DATA of its Model Number and Firmware Version
        (IDENTITY_BYTES from IDENTITY_ADDRESS), or None."""
        try:
            return self.servo.exchange(READ_DATA, [IDENTITY_ADDRESS, IDENTITY_BYTES])
        except (NoAnswer, BadChecksum):
            return None

    def request_bootloader(self):
        """Instruction 0x0A "BOOT" to the application: its answer (None if none came)."""
        try:
            return self.servo.exchange(BOOT, BOOT_PARAMS)
        except (NoAnswer, BadChecksum):
            return None

    def page(self, address, data):
        """Writes one page; a read-back error (0x20) is tried again. The answer carries the
        address back."""
        self.ask(PAGE, u16(address) + list(data), f"PAGE 0x{address:04X}", retry_errors=ERR_READ_BACK,
                 echo=bytes(u16(address)))

    def read_page(self, address, page_bytes):
        """The page_bytes flash bytes of the page at address (a page of the application
        area)."""
        answer = self.ask(READ, u16(address), f"READ 0x{address:04X}")
        if len(answer.params) != page_bytes:
            raise BootError(f"READ 0x{address:04X}: servo {self.ident} answered {len(answer.params)} bytes, "
                            f"not a page of {page_bytes}")
        return bytes(answer.params)

    def go(self):
        """GO once (the application may already run when the answer is lost): the answer, or
        None when none came. The bootloader answers, then starts the application if it is
        valid and stays otherwise."""
        try:
            return self.servo.exchange(GO)
        except (NoAnswer, BadChecksum):
            return None
