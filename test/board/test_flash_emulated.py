# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 flash` through the real path: ax12-emu serving three servos (IDs 1, 2, 3)
with the bootloader, over its pseudo-terminal, on both parts: the ATmega88 and the
ATmega328P, with the product's applications.

- ID 2 is updated to the ax12a application and back to the ax12 one: each time it then runs
  that profile (Model Number and Firmware Version as its control table says, the version
  differing between the profiles, and the profile's own power-up CW Compliance Margin), keeps
  its ID, baud and the EEPROM setting written before; IDs 1 and 3 still answer and never
  answered a bootloader packet (the bus log: no status packet of theirs after a packet to
  ID 2).
- Power cuts: the emulator killed (kill -9: the flash and the EEPROM as a power cut at that
  moment leaves them) at random moments of an update (RANDOM_CUTS[mcu] of them, each from a
  seed the test prints), each restarted on the same state folder: servo 2 answers, as its old
  or new application or as the bootloader, IDs 1 and 3 run, and a new update completes.
- A HEX with a flipped data byte (its record checksum then wrong) or cut short: refused, and
  nothing reaches the bus.
- A merged HEX (application and bootloader): refused (exit 2) before the servo is asked into
  its bootloader; the other part's HEX: refused once the bootloader names the servo's part, and
  GO sent; either way the servo then still answers DynamixelSDK's ping (a PING and a READ) as
  its application.
- The emulator killed in the middle of an update: one line, exit 1, no traceback.

The emulator is started by test/sim/python/conftest.py's Emulator.
"""
import csv
import importlib.util
import os
import random
import signal
import subprocess
import sys
import shutil
import tempfile
import time
from pathlib import Path

import pytest

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
BUILD = os.path.abspath(os.environ.get("AX12_BUILD_DIR") or os.path.join(REPO, "build"))
FIRMWARE_DIR = os.environ.get("AX12_FIRMWARE_DIR") or os.path.join(BUILD, "firmware")
os.environ.setdefault("AX12_EMU", os.path.join(BUILD, "model", "tools", "ax12-emu"))
os.environ.setdefault("AX12_FIRMWARE_DIR", FIRMWARE_DIR)
sys.path.insert(0, os.path.join(REPO, "python"))
sys.path.insert(0, os.path.join(REPO, "scripts"))
sys.path.insert(0, os.path.join(REPO, "test", "support"))
import ax12_build  # noqa: E402
import doc_samples  # noqa: E402

ax12_build.ensure(BUILD)


def _sim_helpers():
    """test/sim/python/conftest.py as a module of its own name (it is not this folder's
    conftest): its Emulator runs `ax12-emu serve` and waits for `ready:`."""
    path = os.path.join(REPO, "test", "sim", "python", "conftest.py")
    spec = importlib.util.spec_from_file_location("ax12_sim_emulator", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


Emulator = _sim_helpers().Emulator

import serial  # noqa: E402

import ax12_boot_client as boot  # noqa: E402
import ax12_table as T  # noqa: E402
from ax12_servo_port import BadChecksum, NoAnswer, ServoPort  # noqa: E402

MCUS = ("atmega88", "atmega328p")
BOOT_ELF = {mcu: os.path.join(FIRMWARE_DIR, f"ax12-boot-{mcu}.elf") for mcu in MCUS}
FRONT_DOOR = os.path.join(REPO, "scripts", "ax12")
RANDOM_CUTS = {"atmega88": 20, "atmega328p": 10}


def app_file(mcu, profile, suffix):
    return os.path.join(FIRMWARE_DIR, f"ax12-{profile}-{mcu}.{suffix}")
ITEM = {item.name: item for item in T.ITEMS}
# Firmware Version per profile, as the generated table gives each profile's default.
FIRMWARE_VERSION = {profile: getattr(ITEM["FIRMWARE_VERSION"], f"default_{profile}") for profile in ("ax12", "ax12a")}
# An EEPROM setting of ID 2 written before the updates: the bootloader never writes the EEPROM.
KEPT_SETTING = (T.HIGHEST_LIMIT_TEMP, 77)


def _missing(mcu):
    """What the updates of mcu lack, or None: the bootloader's ELF, the applications beside it,
    an ax12-emu with --bootloader."""
    for path in [BOOT_ELF[mcu]] + [app_file(mcu, profile, suffix) for profile in ("ax12", "ax12a")
                                   for suffix in ("elf", "hex")]:
        if not os.path.exists(path):
            return f"{path} not built: no update over the bus"
    try:
        text = subprocess.run([os.environ["AX12_EMU"], "serve", "--help"], capture_output=True, text=True,
                              timeout=30).stdout
    except OSError as error:
        return f"ax12-emu cannot run: {error}"
    return None if "--bootloader" in text else "this ax12-emu has no --bootloader: no bootloader in its flash"


def needs(mcu):
    """The test of mcu, skipped with the reason while it cannot run."""
    missing = _missing(mcu)
    return pytest.param(mcu, marks=pytest.mark.skipif(missing is not None, reason=str(missing)))


PARTS = [needs(mcu) for mcu in MCUS]


@pytest.fixture
def state_dir():
    """A folder of this test's own (an emulator keeps its state and its log in it)."""
    folder = tempfile.mkdtemp(prefix="ax12-flash-test-")
    yield Path(folder)
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def serve(state_dir):
    started = []

    def start(mcu, *extra):
        emu = Emulator(["--elf", app_file(mcu, "ax12", "elf"), "--bootloader", BOOT_ELF[mcu], "--mcu", mcu,
                        "--ids", "1,2,3", "--fast", "--state-dir", str(state_dir), *extra])
        started.append(emu)
        # `ready:` comes once the servos' USARTs listen, the bootloader's first (the 32.8 ms
        # window for `#` at 57 600 baud after every reset): a packet at 1 Mbps may be lost
        # before the application listens. Wait until every servo answers.
        for ident in (1, 2, 3):
            assert any(exchange(emu.device, ident, boot.PING) for _ in range(10)), f"ID {ident} answers"
        return emu

    yield start
    for emu in started:
        emu.kill()


def flash_command(device, mcu, profile, ident=2, path=None):
    return [FRONT_DOOR, "flash", "--build", BUILD, "--port", device, "--id", str(ident),
            path or app_file(mcu, profile, "hex")]


def flash(device, mcu, profile, ident=2, path=None):
    return subprocess.run(flash_command(device, mcu, profile, ident, path), capture_output=True, text=True,
                          timeout=300)


def exchange(device, ident, instruction, params=(), timeout_s=0.5):
    """One request on the bus; the answer (ax12_packets.Packet), or None."""
    with serial.Serial(device, 1000000, timeout=0.05) as port:
        try:
            return ServoPort(port, ident, timeout_s).exchange(instruction, params)
        except (NoAnswer, BadChecksum) as error:  # the caller's assert fails on None
            print(f"ID {ident}: {error}")
            return None


def ask(device, ident, instruction, params=(), attempts=4):
    """exchange() up to `attempts` times (the emulator on a busy machine may not answer within
    one timeout): the answer, or None."""
    for _ in range(attempts):
        answer = exchange(device, ident, instruction, params)
        if answer is not None:
            return answer
    return None


def read(device, ident, address, count):
    answer = ask(device, ident, boot.READ_DATA, [address, count])
    assert answer is not None and answer.code == 0 and len(answer.params) == count, (ident, address, answer)
    return list(answer.params)


def assert_runs(device, ident, profile):
    """The servo runs the application of this profile, with its ID and 1 Mbps."""
    model_low, model_high, version = read(device, ident, T.MODEL_NUMBER, 3)
    assert model_low | (model_high << 8) == getattr(ITEM["MODEL_NUMBER"], f"default_{profile}")
    assert version == FIRMWARE_VERSION[profile]
    margin = getattr(ITEM["CW_COMPLIANCE_MARGIN"], f"default_{profile}")
    assert read(device, ident, T.CW_COMPLIANCE_MARGIN, 1) == [margin], "the profile's power-up value"
    assert read(device, ident, T.ID, 2) == [ident, 1], "ID and Baud Rate kept"


def bus_rows(path):
    with open(path, newline="") as f:
        return sorted(csv.DictReader(f), key=lambda row: float(row["time_us"]))


@pytest.mark.parametrize("mcu", PARTS)
def test_update_over_the_bus_changes_one_servo_only(serve, state_dir, mcu):
    log = state_dir / "bus.csv"
    emu = serve(mcu, "--log-bus", str(log))
    assert ask(emu.device, 2, T.INST_WRITE, list(KEPT_SETTING)).code == 0
    for profile in ("ax12a", "ax12"):
        started = time.monotonic()
        run = flash(emu.device, mcu, profile)
        assert run.returncode == 0, run.stdout + run.stderr
        print(f"{mcu}: update to {profile}: {time.monotonic() - started:.2f} s (--fast)")
        model, version = ITEM["MODEL_NUMBER"].default_ax12, FIRMWARE_VERSION[profile]
        assert f"verified; the application runs: Model Number {model}, Firmware Version {version}" in run.stdout, \
            run.stdout
        assert f"bootloader 2 on an {mcu}" in run.stderr
        if (mcu, profile) == ("atmega328p", "ax12a"):
            doc_samples.check("flash-result", run.stdout)
        assert_runs(emu.device, 2, profile)
        assert read(emu.device, 2, KEPT_SETTING[0], 1) == [KEPT_SETTING[1]], "the EEPROM is not the bootloader's"
        for other in (1, 3):
            assert_runs(emu.device, other, "ax12")
    emu.stop()

    rows = bus_rows(log)
    bootloader_instructions = (boot.INFO, boot.PAGE, boot.READ, boot.GO, boot.BOOT)
    sent_to_bootloader = [row for row in rows if row["sender"] == "client" and row["kind"] == "instruction"
                          and row["id"] == "2" and int(row["raw"].split()[4], 16) in bootloader_instructions]
    assert len(sent_to_bootloader) >= 2 * 100, "both updates are in the log"
    last_client_id = None
    for row in rows:
        if row["sender"] == "client":
            last_client_id = row["id"]
        elif row["sender"] in ("servo-1", "servo-3"):
            assert row["id"] == last_client_id, f"{row['sender']} answered a packet to ID {last_client_id}: {row}"


def servo_state(device, ident=2):
    """"bootloader" or the profile of the application the servo runs, or None when it does not
    answer as either."""
    for _ in range(3):
        answer = exchange(device, ident, boot.INFO)
        if boot.parse_info(answer):
            return "bootloader"
        if answer is not None and answer.code & boot.ERR_INSTRUCTION and not answer.params:
            version = read(device, ident, T.FIRMWARE_VERSION, 1)[0]
            return next(profile for profile, value in FIRMWARE_VERSION.items() if value == version)
    return None


@pytest.mark.parametrize("mcu", PARTS)
def test_power_cuts_at_random_moments_of_an_update_leave_a_servo_that_takes_a_new_one(serve, mcu):
    seed = random.randrange(1 << 32)
    chance = random.Random(seed)
    emu = serve(mcu)
    started = time.monotonic()
    run = flash(emu.device, mcu, "ax12a")
    assert run.returncode == 0, run.stdout + run.stderr
    duration = time.monotonic() - started
    profile = "ax12a"
    seen = {}
    for cut in range(RANDOM_CUTS[mcu]):
        target = "ax12" if profile == "ax12a" else "ax12a"
        after = chance.uniform(0.0, duration)
        tool = subprocess.Popen(flash_command(emu.device, mcu, target), stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        time.sleep(after)
        emu.kill(signal.SIGKILL)  # the power cut
        tool.wait(timeout=60)
        emu = serve(mcu)
        state = servo_state(emu.device)
        assert state is not None, f"cut {cut} at {after:.3f} s (seed {seed}): servo 2 answers neither way"
        seen[state] = seen.get(state, 0) + 1
        for other in (1, 3):
            assert_runs(emu.device, other, "ax12")
        run = flash(emu.device, mcu, target)
        assert run.returncode == 0, f"cut {cut} at {after:.3f} s (seed {seed}): " + run.stdout + run.stderr
        assert_runs(emu.device, 2, target)
        profile = target
    print(f"{mcu}: {RANDOM_CUTS[mcu]} cuts in a {duration:.2f} s update (seed {seed}); found after the cut: {seen}")


@pytest.mark.parametrize("which", ["flipped data byte", "truncated"])
def test_a_bad_file_sends_nothing(serve, state_dir, which):
    log = state_dir / "bus.csv"
    emu = serve("atmega328p", "--log-bus", str(log))
    lines = open(app_file("atmega328p", "ax12a", "hex")).read().splitlines()
    if which == "flipped data byte":
        first = lines[0]
        lines[0] = first[:9] + "%02X" % (int(first[9:11], 16) ^ 0x01) + first[11:]
    else:
        lines = lines[:len(lines) // 2]
    bad = state_dir / "bad.hex"
    bad.write_text("\n".join(lines) + "\n")
    run = subprocess.run([FRONT_DOOR, "flash", "--build", BUILD, "--port", emu.device, "--id", "2", str(bad)],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 2, run.stdout + run.stderr
    assert run.stdout == ""
    emu.stop()
    sent = [(row["sender"], row["code_name"]) for row in bus_rows(log) if row["sender"] == "client"]
    assert set(sent) <= {("client", "PING")}, f"only the fixture's PINGs reached the bus: {sent}"


# Files `flash` refuses for a servo of the first part: a merged HEX (the bootloader in it), before
# the port is opened; the other part's build, once the servo's bootloader has named its part.
REFUSED_FILES = [("merged", "atmega88", os.path.join(FIRMWARE_DIR, "ax12-ax12a-atmega88-merged.hex")),
                 ("other part", "atmega88", app_file("atmega328p", "ax12a", "hex"))]


@pytest.mark.parametrize("which,mcu,path", [pytest.param(*case, marks=needs(case[1]).marks) for case in REFUSED_FILES])
def test_a_refused_file_leaves_the_servo_answering_as_its_application(serve, state_dir, which, mcu, path):
    from dynamixel_sdk import COMM_SUCCESS, PacketHandler, PortHandler
    log = state_dir / "bus.csv"
    emu = serve(mcu, "--log-bus", str(log))
    run = flash(emu.device, mcu, None, path=path)
    assert run.returncode == 2, run.stdout + run.stderr
    assert "Traceback" not in run.stderr, run.stderr
    port, handler = PortHandler(emu.device), PacketHandler(1.0)
    assert port.openPort() and port.setBaudRate(1000000)
    try:
        for _ in range(3):  # a busy machine may time one out
            model, result, error = handler.ping(port, 2)
            if result == COMM_SUCCESS:
                break
    finally:
        port.closePort()
    assert (result, error, model) == (COMM_SUCCESS, 0, ITEM["MODEL_NUMBER"].default_ax12), "the SDK's ping of ID 2"
    assert_runs(emu.device, 2, "ax12")
    emu.stop()
    sent = [int(row["raw"].split()[4], 16) for row in bus_rows(log) if row["sender"] == "client"
            and row["kind"] == "instruction" and row["id"] == "2"]
    if which == "merged":
        assert len(run.stderr.strip().splitlines()) == 1, run.stderr
        assert boot.BOOT not in sent, "the servo was never asked into its bootloader"
    else:
        assert "built for the atmega328p, the servo is an atmega88" in run.stderr
        assert "nothing written; its application runs again" in run.stderr
        assert boot.BOOT in sent and boot.GO in sent and boot.PAGE not in sent, sent


@pytest.mark.parametrize("mcu", [needs("atmega328p")])
def test_the_emulator_killed_mid_update_ends_the_command_in_one_line_and_exit_1(serve, mcu):
    emu = serve(mcu)
    proc = subprocess.Popen(flash_command(emu.device, mcu, "ax12a"), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    seen = []
    for line in proc.stderr:  # not a terminal: one line when the writing starts
        seen.append(line)
        if "writing:" in line:
            break
    emu.kill(signal.SIGKILL)
    out, rest = proc.communicate(timeout=60)
    err = "".join(seen) + rest
    assert proc.returncode == 1, out + err
    assert "Traceback" not in err, err
    last = err.strip().splitlines()[-1]
    assert last.startswith(f"ax12 flash: lost the port {emu.device} (") and "run the command again" in last, err
