# SPDX-License-Identifier: GPL-3.0-or-later
"""What the tests of `scripts/ax12 conform` share (test_conform.py, test_imperfect_devices.py):
the emulator (`ax12-emu serve`, with the fixture of the client suites, test/clients/conftest.py)
in a fresh state folder per test, the tool run as a user runs it, its JSON report, the records.

ctest sets AX12_EMU, AX12_FIRMWARE_DIR, AX12_CONFORM_DEFECT_DIR, AX12_FOREIGN_DIR, AX12_BUILD_DIR
and PYTHONPATH. The emulator runs in real time (the tool's timeouts are wall-clock).
"""
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("AX12_BUILD_DIR", REPO / "build"))
TOOL = REPO / "scripts" / "ax12_conform.py"
DEFECTS = Path(os.environ.get("AX12_CONFORM_DEFECT_DIR", BUILD / "test" / "conform" / "defects"))
FOREIGN = Path(os.environ.get("AX12_FOREIGN_DIR", BUILD / "test" / "conform" / "foreign"))
sys.path.insert(0, str(REPO / "python"))
import ax12_build  # noqa: E402

ax12_build.ensure(str(BUILD))
import ax12_conformance_records as R  # noqa: E402

_spec = importlib.util.spec_from_file_location("clients_conftest", REPO / "test" / "clients" / "conftest.py")
clients = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(clients)


@pytest.fixture
def tmp_path():
    """A folder of this test's own: pytest's numbered temporary folders are shared by every
    pytest run of the user, and a run started elsewhere may delete ours while an emulator keeps
    its state in it."""
    folder = tempfile.mkdtemp(prefix="ax12-conform-test-")
    yield Path(folder)
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def serve(tmp_path):
    """start(profile, extra, state_dir): an emulator serving one servo; its control socket is
    <state dir>/control.sock (the emulator's `control` attribute)."""
    started = []

    def start(profile="ax12", extra=(), state_dir=None):
        emu = clients._find_emulator()
        if emu is None:
            pytest.fail("ax12-emu not found: set AX12_EMU")
        folder = Path(state_dir or tmp_path / ("state%d" % len(started)))
        e = clients.Emulator(emu, folder, profile=profile, extra=list(extra))
        started.append(e)
        e.start()
        e.control = folder / "control.sock"
        return e

    yield start
    for e in started:
        e.stop()


def foreign(name):
    """The ELF of a foreign servo build (test/conform/CMakeLists.txt: foreign-<name>.elf)."""
    elf = FOREIGN / ("foreign-%s.elf" % name)
    assert elf.exists(), "build the foreign servo first (cmake --build): %s" % elf
    return ["--mcu", "atmega328p", "--elf", str(elf)]


def conform(*args, timeout=300):
    cmd = [sys.executable, str(TOOL), "--build", str(BUILD)] + [str(a) for a in args]
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=timeout)
    assert "Traceback" not in proc.stderr, proc.stderr
    return proc


def run_report(tmp_path, emu, *args, eeprom=True, bus=True):
    """The tool's run on the emulator emu (with --allow-eeprom unless eeprom is False; timed on
    its bus, --emulator, unless bus is False: then its timeouts are the wall clock's, which a
    busy host can make a device seem to miss) and its JSON report."""
    report = tmp_path / "report.json"
    proc = conform("--port", emu.path, *(["--allow-eeprom"] if eeprom else []),
                   *(["--emulator", emu.control] if bus else []), "--report", report, *args)
    assert report.exists(), proc.stdout + proc.stderr
    return proc, json.loads(report.read_text())


def failing(report):
    return {(c["group"], c["name"]) for c in report["cases"] if c["status"] == "failed"}


def ran(report):
    return [c for c in report["cases"] if c["status"] in ("passed", "failed")]


RECORDS = {}


def records(profile):
    if profile not in RECORDS:
        RECORDS[profile] = R.run_tests(str(BUILD), (profile,))
    return RECORDS[profile]
