"""Fixtures that run `ax12-emu serve` for the real-client suites.

The emulator is found through the environment:
  AX12_EMU           path of the ax12-emu binary (or of `scripts/ax12`, which takes `serve`);
                     when unset, the usual build folders are searched.
  AX12_FIRMWARE_DIR  folder of the AVR ELFs, passed on to the emulator (environment and its
                     --firmware-dir option when the emulator has one).
  AX12_EMU_ARGS      extra arguments appended to every `serve` command line (optional), e.g.
                     `--adapter u2d2:16` to run a suite behind another USB adapter model.
  AX12_EMU_READY_TIMEOUT  seconds to wait for `ready:` (default 30).

State folders live under pytest's temporary directory (`--basetemp DIR` moves them).

The tests take addresses and error bits from ax12_table, generated from firmware/core/ct_items.h
by the build: ctest puts it on PYTHONPATH; run by hand, the one of build/ is used.

Each emulator runs in real time (the default), because every client has wall-clock timeouts
(DynamixelSDK ~34 ms, pyax12 sleeps 20 ms, pypot 50 ms), and in a fresh temporary state folder,
so every servo starts from factory defaults with the IDs asked for.
"""
import glob
import os
import select
import shlex
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "python"))
import ax12_build  # noqa: E402

ax12_build.ensure(str(REPO / "build"))

READY_TIMEOUT_S = float(os.environ.get("AX12_EMU_READY_TIMEOUT", "30"))


def _find_emulator():
    env = os.environ.get("AX12_EMU")
    if env:
        return env
    for path in sorted(glob.glob(str(REPO / "build" / "**" / "ax12-emu"), recursive=True)):
        if os.path.isfile(path) and os.access(path, os.X_OK):
            return path
    return None


def _find_firmware_dir(emu):
    env = os.environ.get("AX12_FIRMWARE_DIR")
    if env:
        return env
    # The ELFs come from the same build as the emulator: <build>/firmware/ax12-*.elf.
    here = Path(emu).resolve().parent
    for parent in [here, *here.parents]:
        for cand in (parent / "firmware", parent):
            if glob.glob(str(cand / "ax12-*.elf")):
                return str(cand)
    return None   # the emulator's own default (the build it came from)


def _help_text(emu):
    try:
        out = subprocess.run([emu, "serve", "--help"], capture_output=True, text=True,
                             timeout=max(READY_TIMEOUT_S, 30))
        return out.stdout + out.stderr
    except (OSError, subprocess.SubprocessError):
        return ""


class Emulator:
    """One `ax12-emu serve` process; `path` is the device the clients open."""

    def __init__(self, emu, state_dir, ids="1", profile="ax12", extra=()):
        self.emu = emu
        self.state_dir = Path(state_dir)
        self.ids = ids
        self.profile = profile
        self.extra = list(extra)
        self.proc = None
        self.path = None
        self._stdout_lines = []
        self._stderr_path = self.state_dir / "emulator.stderr"

    @property
    def command(self):
        cmd = [self.emu, "serve", "--ids", str(self.ids), "--profile", self.profile,
               "--state-dir", str(self.state_dir)]
        fw = _find_firmware_dir(self.emu)
        if fw and "--firmware-dir" in _cached_help(self.emu):
            cmd += ["--firmware-dir", fw]
        if "--stats" in _cached_help(self.emu):
            cmd += ["--stats"]      # timing statistics on stderr at exit, shown on failure
        cmd += shlex.split(os.environ.get("AX12_EMU_ARGS", ""))
        return cmd + self.extra

    def start(self):
        self.state_dir.mkdir(parents=True, exist_ok=True)
        env = dict(os.environ)
        fw = _find_firmware_dir(self.emu)
        if fw:
            env["AX12_FIRMWARE_DIR"] = fw
        self._stderr = open(self._stderr_path, "ab")
        self.proc = subprocess.Popen(self.command, stdout=subprocess.PIPE, stderr=self._stderr,
                                     stdin=subprocess.DEVNULL, env=env)
        deadline = time.monotonic() + READY_TIMEOUT_S
        buf = b""
        fd = self.proc.stdout.fileno()
        while self.path is None:
            left = deadline - time.monotonic()
            if left <= 0:
                self.stop()
                raise RuntimeError(f"no 'ready:' line within {READY_TIMEOUT_S} s from "
                                   f"{self.command}\n{self.stderr_text()}")
            ready, _, _ = select.select([fd], [], [], min(left, 0.5))
            if not ready:
                if self.proc.poll() is not None:
                    break
                continue
            chunk = os.read(fd, 4096)
            if not chunk:
                break
            buf += chunk
            while b"\n" in buf:
                line, buf = buf.split(b"\n", 1)
                text = line.decode(errors="replace").strip()
                self._stdout_lines.append(text)
                if text.startswith("ready:"):
                    self.path = text[len("ready:"):].strip()
        if self.path is None:
            rc = self.proc.poll()
            self.stop()
            raise RuntimeError(f"emulator exited (rc={rc}) before 'ready:': {self.command}\n"
                               f"stdout: {self._stdout_lines}\n{self.stderr_text()}")
        # Keep draining stdout so a chatty emulator never blocks on a full pipe.
        threading.Thread(target=self._drain, daemon=True).start()
        return self

    def _drain(self):
        try:
            for line in self.proc.stdout:
                self._stdout_lines.append(line.decode(errors="replace").rstrip())
        except (OSError, ValueError):
            pass

    def stderr_text(self):
        try:
            return "emulator stderr:\n" + self._stderr_path.read_text(errors="replace")[-4000:]
        except OSError:
            return ""

    def stop(self):
        if self.proc is None:
            return
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=10)
        if self.proc.stdout:
            self.proc.stdout.close()
        self._stderr.close()
        self.returncode = self.proc.returncode
        self.proc = None

    def restart(self):
        """Power cycle: stop, then start again on the same state folder (EEPROM kept)."""
        self.stop()
        self.path = None
        return self.start()


_help_cache = {}


def _cached_help(emu):
    if emu not in _help_cache:
        _help_cache[emu] = _help_text(emu)
    return _help_cache[emu]


class EmulatorFactory:
    def __init__(self, base_dir):
        self.base_dir = Path(base_dir)
        self.emulators = []

    def __call__(self, ids="1", profile="ax12", extra=(), state_dir=None):
        emu = _find_emulator()
        if emu is None:
            pytest.skip("ax12-emu not found: set AX12_EMU to the built binary "
                        "(cmake --build <build>; <build>/model/tools/emu/ax12-emu)")
        if not os.access(emu, os.X_OK):
            pytest.fail(f"AX12_EMU={emu} is not an executable ax12-emu")
        if state_dir is None:
            state_dir = self.base_dir / f"state{len(self.emulators)}"
        e = Emulator(emu, state_dir, ids=ids, profile=profile, extra=extra)
        self.emulators.append(e)
        return e.start()

    def stop_all(self):
        for e in self.emulators:
            e.stop()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    rep = outcome.get_result()
    setattr(item, "rep_" + rep.when, rep)


def _report_failure(request, factory):
    rep = getattr(request.node, "rep_call", None)
    if rep is not None and rep.failed:
        for e in factory.emulators:
            print(f"\n--- {' '.join(e.command)}\n{e.stderr_text()}")


@pytest.fixture
def emulators(tmp_path, request):
    """Start emulators inside one test: `emulators(ids="1-6", profile="ax12")`."""
    factory = EmulatorFactory(tmp_path)
    yield factory
    factory.stop_all()
    _report_failure(request, factory)


@pytest.fixture(scope="module")
def module_emulators(tmp_path_factory):
    """Emulators shared by a module's tests; only for tests that restore what they change."""
    factory = EmulatorFactory(tmp_path_factory.mktemp("emu"))
    yield factory
    factory.stop_all()
