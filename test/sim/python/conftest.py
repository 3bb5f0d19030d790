# SPDX-License-Identifier: GPL-3.0-or-later
"""Helpers for the ax12-emu tests: start `ax12-emu serve`, wait for its `ready:` line. ctest
sets AX12_EMU, AX12_FIRMWARE_DIR and PYTHONPATH (the packets of python/ax12_packets.py, the
table generated from ct_items.h); run by hand, the table of build/ is used."""
import os
import select
import signal
import subprocess
import sys
import time

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
sys.path.insert(0, os.path.join(REPO, "python"))
import ax12_build  # noqa: E402

ax12_build.ensure(os.path.join(REPO, "build"))

EMU = os.environ.get("AX12_EMU", "")
FIRMWARE_DIR = os.environ.get("AX12_FIRMWARE_DIR", "")
FIRMWARE_REQUIRED = os.environ.get("AX12_FIRMWARE_REQUIRED", "1") == "1"


def world(*args):
    """`scripts/ax12 world` with these arguments: its completed process."""
    return subprocess.run([sys.executable, os.path.join(REPO, "scripts", "ax12_world.py")] + list(args),
                          capture_output=True, text=True, timeout=30)


def wait_for(predicate, timeout_s, what):
    """predicate()'s first true value within timeout_s of wall time, polled every 50 ms."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.05)
    pytest.fail("timed out waiting for " + what)


def servo(status, slot):
    """The servo of a control-socket status with that slot (its --ids entry)."""
    return next(s for s in status["servos"] if s["slot"] == slot)


class Emulator:
    def __init__(self, args, timeout=20.0, emu_command=None):
        """emu_command: the program and what runs it (["taskset", "-c", "0", EMU]); default EMU."""
        self.args = list(emu_command or [EMU]) + ["serve"] + list(args)
        self.proc = subprocess.Popen(self.args, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        self.device = None
        line = b""
        deadline = time.monotonic() + timeout
        while not line.endswith(b"\n"):
            left = deadline - time.monotonic()
            if left <= 0 or self.proc.poll() is not None:
                break
            ready, _, _ = select.select([self.proc.stdout], [], [], left)
            if ready:
                chunk = os.read(self.proc.stdout.fileno(), 1)
                if not chunk:
                    break
                line += chunk
        if not line.startswith(b"ready: "):
            err = self.proc.stderr.read1(4096).decode(errors="replace") if self.proc.poll() is not None else ""
            self.kill()
            raise RuntimeError(f"ax12-emu did not get ready: {line!r} {err}")
        self.device = line[len(b"ready: "):].strip().decode()

    def kill(self, sig=signal.SIGKILL):
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        return self.proc.wait(timeout=20)

    def stop(self):
        return self.kill(signal.SIGTERM)


@pytest.fixture
def emulator():
    if not EMU or not os.access(EMU, os.X_OK):
        pytest.fail("AX12_EMU does not name the ax12-emu program")
    elf = os.path.join(FIRMWARE_DIR, "ax12-ax12-atmega88.elf")
    if not os.path.exists(elf):
        if FIRMWARE_REQUIRED:
            pytest.fail(f"firmware ELF missing: {elf}")
        pytest.skip(f"no firmware ELF {elf}")
    started = []

    def start(*args, **kwargs):
        emu = Emulator(["--firmware-dir", FIRMWARE_DIR] + list(args), **kwargs)
        started.append(emu)
        return emu

    yield start
    for emu in started:
        emu.kill()
