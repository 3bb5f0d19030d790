# SPDX-License-Identifier: GPL-3.0-or-later
"""The classroom labs (docs/labs/) done as a student does them, and their sample outputs checked
(test/support/doc_samples.py): each lab's programs are taken from its page ("Save this as
`NAME.py`" and the Python block after it), the emulator started with the options of the page's
`scripts/ax12 serve` line (its /tmp folders made this test's own, without the dashboard), the
world changed with the page's `scripts/ax12 world` lines, and what the programs print compared
with the page's samples. DynamixelSDK drives the emulator in real time, so times, and figures
that move with them (a temperature, a position while it moves), are compared within a
tolerance or not at all; the rest to the count.

ctest sets AX12_EMU, AX12_FIRMWARE_DIR, AX12_BUILD_DIR and PYTHONPATH.
"""
import os
import re
import select
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "test" / "support"))
import doc_samples  # noqa: E402

EMU = os.environ.get("AX12_EMU", str(REPO / "build" / "model" / "tools" / "ax12-emu"))
FIRMWARE_DIR = os.environ.get("AX12_FIRMWARE_DIR", str(REPO / "build" / "firmware"))
PYTHON = str(REPO / ".venv" / "bin" / "python")
LABS = REPO / "docs" / "labs"


@pytest.fixture
def folder():
    path = Path(tempfile.mkdtemp(prefix="ax12-lab-test-"))
    yield path
    shutil.rmtree(path, ignore_errors=True)


# --- the lab's page -------------------------------------------------------------------------------

def page(name):
    return next(LABS.glob(name + "*.md")).read_text()


def programs(text, folder):
    """Writes each program the page asks to save ("Save this as `NAME.py`", then its Python
    block) into folder; returns {NAME.py: path}."""
    saved = {}
    for m in re.finditer(r"Save this as `([\w.]+\.py)`.*?```python\n(.*?)```", text, re.S):
        path = folder / m.group(1)
        path.write_text(m.group(2))
        saved[m.group(1)] = path
    return saved


def commands(text, program):
    """The page's shell lines that start with `program` (e.g. "scripts/ax12 serve"), as
    argument lists after it."""
    out = []
    for block in re.findall(r"```sh\n(.*?)```", text, re.S):
        for line in block.splitlines():
            line = line.split("#")[0].strip()
            if line.startswith(program + " "):
                out.append(shlex.split(line[len(program):]))
    return out


def own_paths(args, folder):
    """The page's /tmp/labN... paths as this test's own folder's."""
    return [re.sub(r"^/tmp/", str(folder) + "/", a) for a in args]


class Serve:
    """ax12-emu serve with a page's options (no dashboard: no browser here), up to `ready:`."""

    def __init__(self, args, folder):
        args = list(args)
        if "--dashboard" in args:
            at = args.index("--dashboard")
            del args[at:at + 2]
        self.proc = subprocess.Popen([EMU, "serve", "--firmware-dir", FIRMWARE_DIR, *own_paths(args, folder)],
                                     stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        ready, _, _ = select.select([self.proc.stdout], [], [], 60)
        line = self.proc.stdout.readline() if ready else ""
        if not line.startswith("ready: "):
            self.proc.kill()
            pytest.fail("ax12-emu did not get ready: %r" % line)
        self.device = line.split(" ", 1)[1].strip()

    def stop(self):
        self.proc.send_signal(signal.SIGINT)
        assert self.proc.wait(timeout=60) == 0


def run(program, *args, timeout=120):
    """A lab program (or a script of the repository) with the project's Python: its stdout."""
    proc = subprocess.run([PYTHON, str(program), *map(str, args)], capture_output=True, text=True, timeout=timeout)
    if "no whole answer in 5 tries" in proc.stderr:
        raise HeldByThePty(proc.stderr)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stdout + proc.stderr
    return proc.stdout


def world(args, folder):
    """One of the page's `scripts/ax12 world` lines."""
    return run(REPO / "scripts" / "ax12_world.py", *own_paths(args, folder))


class HeldByThePty(Exception):
    """A lab program's request timed out (it printed so, or sent it again): on a loaded machine
    the kernel's pty can hold a packet past DynamixelSDK's timeout (docs/emulator.md "pty
    limit"). Not what the lab shows: the lab is done again, from a fresh folder."""


def in_attempts(lab, folder, attempts=3):
    """lab(its own folder) again, up to attempts times, while the pty held a packet."""
    for attempt in range(attempts):
        own = folder / ("attempt%d" % attempt)
        own.mkdir()
        try:
            return lab(own)
        except HeldByThePty as held:
            last = held
    pytest.fail("the pty held a packet in every one of %d attempts: %s" % (attempts, last))


def not_held(text, *symptoms):
    """text, unless it shows a request that timed out (one of symptoms)."""
    for symptom in symptoms:
        if symptom in text:
            raise HeldByThePty("%r in %r" % (symptom, text))
    return text


def first_run(text, folder, program, *symptoms):
    """A lab's start: its programs saved, the emulator of its first `scripts/ax12 serve` line,
    `program` run against it (not_held: none of symptoms) and the emulator stopped. Returns the
    programs, the page's serve lines and what the program printed."""
    saved = programs(text, folder)
    serve_lines = commands(text, "scripts/ax12 serve")
    serve = Serve(serve_lines[0], folder)
    try:
        return saved, serve_lines, not_held(run(saved[program], serve.device), *symptoms)
    finally:
        serve.stop()


# --- comparing real-time figures ------------------------------------------------------------------

def numbers_alike(sample, output, tolerances, pattern=r"-?\d+(?:\.\d+)?"):
    """Whether two lines are alike but for numbers, the k-th number within tolerances[k]
    (None: any value)."""
    split = re.compile("(" + pattern + ")")
    a, b = split.split(sample), split.split(output)
    words = lambda parts: [" ".join(p.split()) for p in parts[0::2]]  # noqa: E731 (columns: any width)
    if len(a) != len(b) or words(a) != words(b):
        return False
    values = list(zip(a[1::2], b[1::2]))
    if len(values) != len(tolerances):
        return False
    return all(t is None or abs(float(x) - float(y)) <= t for (x, y), t in zip(values, tolerances))


def lab_times_masked(line):
    """A line of a bus log or a waveform reader with its times (simulated us, which depend on
    when the program ran) masked, and a packet's duration kept."""
    m = re.match(r"^(\d+\.\d{4}),(\d+\.\d{4}),(.*)$", line)
    if m:
        return "%.4f us,%s" % (float(m.group(2)) - float(m.group(1)), m.group(3))
    return re.sub(r"^\s*\d+\.\d{4} us", "T us", line)


# --- lab 1 ---------------------------------------------------------------------------------------

STEP_LINE = r"^(slope \d+, margin \d+, punch \d+:)"


def step_end_alike(sample, output):
    """A run's last line: the time any; position and error within 2 counts; Present Load within
    40 (a count of friction), or, while hunting at punch 300, one of 0 and +-305."""
    label = re.match(STEP_LINE, sample)
    if not label or not output.startswith(label.group(1)):
        return False
    strip = lambda line: line[len(label.group(1)):]  # noqa: E731
    if not numbers_alike(strip(sample), strip(output), [None, 2, 2, None]):
        return False
    load = lambda line: int(line.split("load")[1])  # noqa: E731
    if label.group(1).endswith("punch 300:"):
        return abs(load(output)) < 5 or abs(abs(load(output)) - 305) <= 10
    return abs(load(sample) - load(output)) <= 40


def test_lab1_compliance(folder):
    text = page("01")

    def step(program, device, *settings):
        """lab1_step.py's lines; the run again when reads timed out: fewer than one every 60 ms
        of its 0.6 s (the page: one every 20-30 ms)."""
        lines = run(program, device, *settings).splitlines()
        if len(lines) < 10:
            raise HeldByThePty("%d reads in 0.6 s: %s" % (len(lines), lines))
        return lines

    def lab(folder):
        saved = programs(text, folder)
        serve = Serve(commands(text, "scripts/ax12 serve")[0], folder)
        try:
            ends = []
            for slope, margin, punch in ((32, 0, 32), (128, 0, 32), (128, 10, 32), (128, 0, 300)):
                lines = step(saved["lab1_step.py"], serve.device, slope, margin, punch)
                ends.append(("slope %d, margin %d, punch %d:" % (slope, margin, punch)).ljust(31) + lines[-1])
            doc_samples.check("lab1-step-ends", "\n".join(ends), same=step_end_alike)

            step(saved["lab1_step.py"], serve.device, 32, 0, 32)  # part 4: holding 612
            reads = []
            for args in commands(text, "scripts/ax12 world"):
                world(args, folder)
                if "--load-torque" in args:
                    time.sleep(2.0)
                    reads.append(run(saved["lab1_read.py"], serve.device).strip())
            doc_samples.check("lab1-holding", "\n".join(reads), same=lambda a, b: numbers_alike(a, b, [0, 2, 2, 40]))
        finally:
            serve.stop()
    in_attempts(lab, folder)


# --- lab 2 ---------------------------------------------------------------------------------------

def test_lab2_bus_timing(folder):
    text = page("02")

    def lab(folder):
        saved, serve_lines, pings = first_run(text, folder, "lab2_ping.py", "did not answer")
        doc_samples.check("lab2-broadcast-ping", pings)
        log, trace = folder / "lab2.csv", folder / "lab2.vcd"
        cut = subprocess.run(["cut", "-d,", "-f1-7,10", str(log)], capture_output=True, text=True, check=True).stdout
        if cut.count(",client,instruction,") != 5:  # two PINGs, three WRITEs: none sent again
            raise HeldByThePty("a request sent again: %s" % cut)
        doc_samples.check("lab2-bus-log", cut, lab_times_masked)
        doc_samples.check("lab2-dir-pins", run(saved["lab2_vcd.py"], trace), lab_times_masked)

        other = Serve(serve_lines[1], folder)  # part 5: the AX-12A's behaviour
        try:
            pings = not_held(run(saved["lab2_ping.py"], other.device), "did not answer")
            assert pings.splitlines() == ["0 bytes back: "] * 2, pings
        finally:
            other.stop()
    in_attempts(lab, folder)


# --- lab 3 ---------------------------------------------------------------------------------------

STALL_LINE = r"^\s*(\d+\.\d) s  position\s+(\d+)  load\s+(-?\d+)\s+(\d+) degC  torque (\d)  error (0x\w\w)(.*)$"


def stall_alike(sample, output):
    """A line of lab3_stall.py: the time, the temperature and a position while the shaft moves
    (on its way to the stall, or falling back) any; the torque, the error bits and the load
    exact; the stalled position (torque on, Overload) within 3 counts."""
    a, b = re.match(STALL_LINE, sample), re.match(STALL_LINE, output)
    if not a or not b:
        return sample == output
    if a.group(5, 6, 7) != b.group(5, 6, 7) or a.group(3) != b.group(3):
        return False
    stalled = a.group(5) == "1" and "OVERLOAD" in a.group(7)
    return not stalled or abs(int(a.group(2)) - int(b.group(2))) <= 3


def world_now_alike(sample, output):
    """`scripts/ax12 world`'s lines: the temperatures (they climb by the second) any, the rest
    within a little of the sample's."""
    if sample.lstrip().startswith("now:"):
        return numbers_alike(sample, output, [3, 0.2, 0.05, 0.05, None, None, 0.1, 0.1])
    return sample == output


def test_lab3_alarms_heat(folder):
    text = page("03")
    worlds = commands(text, "scripts/ax12 world")
    seconds = int(re.search(r"lab3_stall\.py /dev/pts/N (\d+)", text).group(1))

    def lab(folder):
        saved = programs(text, folder)
        serve = Serve(commands(text, "scripts/ax12 serve")[0], folder)
        try:
            seen = {}

            def at_20_s():
                time.sleep(21.0)
                seen["world"] = world(worlds[0], folder)
            asking = threading.Thread(target=at_20_s)
            asking.start()
            stall = run(saved["lab3_stall.py"], serve.device, seconds, timeout=seconds + 60)
            asking.join()
            # DynamixelSDK takes an answer the pty handed over late for the next request's: a
            # Torque Enable that is neither 0 nor 1 is one.
            if re.search(r"torque (?![01] )\d+", stall):
                raise HeldByThePty("a late answer taken for a read: %s" % stall)
            doc_samples.check("lab3-stall", stall, same=stall_alike)
            doc_samples.check("lab3-world", seen["world"], same=world_now_alike)

            world(worlds[1], folder)  # part 2: the air at 25 degC, until overheating clears
            deadline = time.monotonic() + 60
            while "alarm conditions 0x20" not in world(worlds[0], folder) and time.monotonic() < deadline:
                time.sleep(1.0)
            doc_samples.check("lab3-overload", run(saved["lab3_overload.py"], serve.device),
                              lambda line: re.sub(r"^\d+\.\d\d s", "T s", line))
        finally:
            serve.stop()
    in_attempts(lab, folder, attempts=2)


# --- lab 4 ---------------------------------------------------------------------------------------

def test_lab4_eeprom_lock_regwrite(folder):
    text = page("04")

    def lab(folder):
        saved, serve_lines, writes = first_run(text, folder, "lab4_writes.py", "None")
        if any(int(value) > 1023 for value in re.findall(r"(?:Goal|Present) (\d+)", writes)):
            raise HeldByThePty("a late answer taken for a read: %s" % writes)  # DynamixelSDK's
        grep = subprocess.run(["grep", "-E", "REG_WRITE|ACTION", "-A1", str(folder / "lab4.csv")],
                              capture_output=True, text=True, check=True).stdout
        if grep.count(",REG_WRITE,") != 2:
            raise HeldByThePty("a REG_WRITE sent again: %s" % grep)
        doc_samples.check("lab4-writes", writes)
        doc_samples.check("lab4-log", grep, lab_times_masked)
        again = Serve(serve_lines[1], folder)  # part 4: the power cycle
        try:
            doc_samples.check("lab4-read-back", run(saved["lab4_read_back.py"], again.device))
        finally:
            again.stop()
    in_attempts(lab, folder)


# --- lab 5 ---------------------------------------------------------------------------------------

HOLD_LINE = re.compile(r"^slope (\d+): position (\d+), droop (-?\d+) counts, Present Load (-?\d+)$", re.M)
ARM_LINE = re.compile(r"^(\w+)\s+goal (\d+)  position (\d+)  error\s+(-?\d+)  Present Load\s+(-?\d+)$", re.M)


def law_drive(error, slope):
    """docs/control.md's compliance law at the factory margin 0, Punch 32, Torque Limit 1023."""
    k = max(1, (slope - 1).bit_length())
    return 0 if error == 0 else min(1023, 32 + ((991 * abs(error)) >> k))


def hold_alike(sample, output):
    """A line of lab5_hold.py: the droop within a count of the sample's (a joint's friction stops
    it a count either way), the position with it, and Present Load the law's drive at the droop
    the run shows."""
    a, b = HOLD_LINE.match(sample), HOLD_LINE.match(output)
    if not a or not b or a.group(1) != b.group(1):
        return False
    slope, position, droop, load = (int(g) for g in b.groups())
    return (abs(droop - int(a.group(3))) <= 1 and position == 512 - droop
            and load == law_drive(droop, slope))


def arm_alike(sample, output):
    """A line of lab5_arm.py (slope 32): the error within a count of the sample's, the position
    with it, and Present Load the law's drive at that error, clockwise when the joint is past
    its goal."""
    a, b = ARM_LINE.match(sample), ARM_LINE.match(output)
    if not a or not b or a.group(1, 2) != b.group(1, 2):
        return False
    goal, position, error, load = (int(g) for g in b.group(2, 3, 4, 5))
    return (abs(error - int(a.group(4))) <= 1 and position == goal - error
            and load == (1 if error > 0 else -1) * law_drive(error, 32))


def world_joint_alike(sample, output):
    """`scripts/ax12 world --servo 1` on the held pendulum: the angle within a count (0.3 deg),
    duty and motor current within 0.02 (one count of drive), temperatures and the robot's clock
    any, the load torque within 0.02 N m, the firmware's line as the hold's: position within a
    count, load within the law's step of it."""
    if sample.lstrip().startswith("now:"):
        return numbers_alike(sample, output, [0.3, 0.1, 0.02, 0.02, None, None, 0.02, 0.02])
    if sample.lstrip().startswith("firmware:"):
        return numbers_alike(sample, output, [0, 1, 10, 0, 0])
    if sample.startswith("robot at"):
        return numbers_alike(sample, output, [None, 0], pattern=r"\d+\.\d+")
    return sample == output


def gravity_alike(sample, output):
    """lab5_joints.py's lines: the step count and the times since the start any (they follow the
    student's pace), the fall's duration within 20 ms, angles within 0.3 deg (a count), counts
    within one."""
    tolerances = {"joint": [None, None], "last": [0.3, 1, None], "90 %": [0, 0.02, 0.3, 1], "now": [0.3, 1]}
    key = next((k for k in tolerances if sample.startswith(k)), None)
    return key is not None and numbers_alike(sample, output, tolerances[key])


def test_lab5_robot_arm(folder):
    text = page("05")
    predict_runs = commands(text, ".venv/bin/python lab5_predict.py")
    worlds = commands(text, "scripts/ax12 world")

    def lab(folder):
        saved = programs(text, folder)
        predictions = "".join(run(saved["lab5_predict.py"], *args) for args in predict_runs)
        doc_samples.check("lab5-predict", predictions)
        predicted = {m.group(1, 2): int(m.group(3)) for m in re.finditer(
            r"^([\d.]+) N m at slope (\d+): droop (\d+) counts", predictions, re.M)}

        def hold(device, slope):
            return not_held(run(saved["lab5_hold.py"], device, slope), "no whole answer")

        serve_lines = commands(text, "scripts/ax12 serve")
        serve = Serve(serve_lines[0], folder)
        try:
            plain = hold(serve.device, 32) + hold(serve.device, 128)
            doc_samples.check("lab5-pendulum", plain, same=hold_alike)
            world(worlds[0], folder)  # 0.3 kg on tip
            loaded = hold(serve.device, 32) + hold(serve.device, 128)
            doc_samples.check("lab5-pendulum-payload", loaded, same=hold_alike)
            doc_samples.check("lab5-world", world(worlds[1], folder), same=world_joint_alike)
            # The droops measured against the page's predictions, within a count.
            for torque, lines in (("0.316", plain), ("0.758", loaded)):
                measured = {m.group(1): int(m.group(3)) for m in HOLD_LINE.finditer(lines)}
                assert sorted(measured) == ["128", "32"], lines
                for slope, droop in measured.items():
                    assert abs(droop - predicted[(torque, slope)]) <= 1, (torque, lines, predicted)
            world(worlds[2], folder)  # gravity off
            time.sleep(2.0)
            world(worlds[3], folder)  # gravity on
            time.sleep(2.0)
        finally:
            serve.stop()
        log = own_paths(commands(text, ".venv/bin/python lab5_joints.py")[0], folder)
        doc_samples.check("lab5-gravity", run(saved["lab5_joints.py"], *log), same=gravity_alike)

        arm = Serve(serve_lines[1], folder)
        try:
            doc_samples.check("lab5-arm", not_held(run(saved["lab5_arm.py"], arm.device, 32), "no whole answer"),
                              same=arm_alike)
            world(worlds[4], folder)  # 0.1 kg on grip
            with_payload = not_held(run(saved["lab5_arm.py"], arm.device, 32), "no whole answer")
            doc_samples.check("lab5-arm-payload", with_payload, same=arm_alike)
            shoulder = next(m for m in ARM_LINE.finditer(with_payload) if m.group(1) == "shoulder")
            assert abs(-int(shoulder.group(4)) - predicted[("0.746", "32")]) <= 1, (with_payload, predicted)
        finally:
            arm.stop()
    in_attempts(lab, folder)
