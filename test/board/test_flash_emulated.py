# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 flash` through the real path: ax12-emu serving three ATmega328P servos (IDs
1, 2, 3) with the bootloader, over its pseudo-terminal.

- ID 2 is updated to the ax12a application and back to the ax12 one: each time it then runs
  that profile (Model Number and Firmware Version as its control table says, the version
  differing between the profiles, and the profile's own power-up CW Compliance Margin), keeps its ID, baud and the
  EEPROM setting written before; IDs 1 and 3 still answer and never answered a bootloader
  packet (the bus log: no status packet of theirs after a packet to ID 2).
- An update cut by kill -9 after BEGIN and after every page: the emulator restarted on the
  same state folder answers INFO as a bootloader with the application not valid, and a new
  update completes. Cut between END and GO: the record is
  written, so the reset starts the new application, and a new update completes too.
- A HEX with a flipped data byte (its record checksum then wrong) or cut short: refused, and
  nothing reaches the bus.
- A HEX for the ATmega88 or a merged one (application and bootloader): refused (exit 2) before
  the servo is asked into its bootloader, which then still answers DynamixelSDK's ping (a PING
  and a READ) as its application.
- The emulator killed in the middle of an update: one line, exit 1, no traceback.

The updates are skipped while the bootloader's ELF (build/firmware/ax12-boot-atmega328p.elf)
is not built, or when the emulator has no --bootloader (the bootloader in its servos' flash).
The emulator is started by test/sim/python/conftest.py's Emulator.
"""
import csv
import importlib.util
import os
import signal
import subprocess
import sys
import shutil
import tempfile
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

import ax12_app_image  # noqa: E402
import ax12_boot_client as boot  # noqa: E402
import ax12_flash  # noqa: E402
import ax12_table as T  # noqa: E402
from ax12_servo_port import BadChecksum, NoAnswer, ServoPort  # noqa: E402

BOOT_ELF = os.path.join(FIRMWARE_DIR, "ax12-boot-atmega328p.elf")
FRONT_DOOR = os.path.join(REPO, "scripts", "ax12")
HEX = {profile: os.path.join(FIRMWARE_DIR, f"ax12-{profile}-atmega328p.hex") for profile in ("ax12", "ax12a")}
# Files `flash` refuses: an ATmega88 build (no bootloader), a merged HEX (the bootloader in it).
REFUSED_HEX = {"atmega88": os.path.join(FIRMWARE_DIR, "ax12-ax12-atmega88.hex"),
               "merged": os.path.join(FIRMWARE_DIR, "ax12-ax12a-atmega328p-merged.hex")}
ITEM = {item.name: item for item in T.ITEMS}
# Firmware Version per profile, as the generated table gives each profile's default.
FIRMWARE_VERSION = {profile: getattr(ITEM["FIRMWARE_VERSION"], f"default_{profile}") for profile in ("ax12", "ax12a")}
# An EEPROM setting of ID 2 written before the updates: the bootloader never writes the EEPROM.
KEPT_SETTING = (T.HIGHEST_LIMIT_TEMP, 77)


def _emulator_without_bootloader():
    """Why the emulator cannot run the bootloader, or None: the bootloader's ELF not built, or
    an ax12-emu without --bootloader."""
    if not os.path.exists(BOOT_ELF):
        return f"{BOOT_ELF} not built (the bootloader): no update over the bus"
    try:
        text = subprocess.run([os.environ["AX12_EMU"], "serve", "--help"], capture_output=True, text=True,
                              timeout=30).stdout
    except OSError as error:
        return f"ax12-emu cannot run: {error}"
    return None if "--bootloader" in text else "this ax12-emu has no --bootloader: no bootloader in its flash"


WITHOUT_BOOTLOADER = _emulator_without_bootloader()
needs_bootloader = pytest.mark.skipif(WITHOUT_BOOTLOADER is not None, reason=str(WITHOUT_BOOTLOADER))


@pytest.fixture
def state_dir():
    """A folder of this test's own (an emulator keeps its state and its log in it)."""
    folder = tempfile.mkdtemp(prefix="ax12-flash-test-")
    yield Path(folder)
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def serve(state_dir):
    started = []

    def start(*extra):
        emu = Emulator(["--firmware-dir", FIRMWARE_DIR, "--mcu", "atmega328p", "--ids", "1,2,3", "--fast",
                        "--state-dir", str(state_dir), *extra])
        started.append(emu)
        # `ready:` comes once the servos' USARTs listen, the bootloader's first (the 30 ms
        # window for `#` at 57 600 baud after every reset): a packet at 1 Mbps may be lost
        # before the application listens. Wait until every servo answers.
        for ident in (1, 2, 3):
            assert any(exchange(emu.device, ident, boot.PING) for _ in range(10)), f"ID {ident} answers"
        return emu

    yield start
    for emu in started:
        emu.kill()


def flash(device, profile, ident=2, path=None):
    return subprocess.run([FRONT_DOOR, "flash", "--build", BUILD, "--port", device, "--id", str(ident),
                           path or HEX[profile]], capture_output=True, text=True, timeout=300)


def exchange(device, ident, instruction, params=(), timeout_s=0.5):
    """One request on the bus; the answer (ax12_packets.Packet), or None."""
    with serial.Serial(device, 1000000, timeout=0.05) as port:
        try:
            return ServoPort(port, ident, timeout_s).exchange(instruction, params)
        except (NoAnswer, BadChecksum) as error:  # the caller's assert fails on None
            print(f"ID {ident}: {error}")
            return None


def read(device, ident, address, count):
    answer = exchange(device, ident, boot.READ_DATA, [address, count])
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


@needs_bootloader
def test_update_over_the_bus_changes_one_servo_only(serve, state_dir):
    log = state_dir / "bus.csv"
    emu = serve("--log-bus", str(log))
    assert exchange(emu.device, 2, T.INST_WRITE, list(KEPT_SETTING)).code == 0
    for profile in ("ax12a", "ax12"):
        run = flash(emu.device, profile)
        assert run.returncode == 0, run.stdout + run.stderr
        model, version = ITEM["MODEL_NUMBER"].default_ax12, FIRMWARE_VERSION[profile]
        assert f"verified; the application runs: Model Number {model}, Firmware Version {version}" in run.stdout, \
            run.stdout
        if profile == "ax12a":
            doc_samples.check("flash-result", run.stdout)
        assert_runs(emu.device, 2, profile)
        assert read(emu.device, 2, KEPT_SETTING[0], 1) == [KEPT_SETTING[1]], "the EEPROM is not the bootloader's"
        for other in (1, 3):
            assert_runs(emu.device, other, "ax12")
    emu.stop()

    rows = bus_rows(log)
    bootloader_instructions = (boot.INFO, boot.BEGIN, boot.PAGE, boot.END, boot.READ, boot.GO, boot.BOOT)
    sent_to_bootloader = [row for row in rows if row["sender"] == "client" and row["kind"] == "instruction"
                          and row["id"] == "2" and int(row["raw"].split()[4], 16) in bootloader_instructions]
    pages = len(ax12_app_image.load(HEX["ax12a"]).pages(128))
    assert len(sent_to_bootloader) >= 2 * (2 * pages + 3), "both updates are in the log"
    last_client_id = None
    for row in rows:
        if row["sender"] == "client":
            last_client_id = row["id"]
        elif row["sender"] in ("servo-1", "servo-3"):
            assert row["id"] == last_client_id, f"{row['sender']} answered a packet to ID {last_client_id}: {row}"


def partial_update(device, profile, cut):
    """An update of ID 2 stopped at `cut`: ("pages", k) after BEGIN and k pages, ("end",) after
    END. The emulator is killed right after by the caller."""
    image = ax12_app_image.load(HEX[profile])
    with serial.Serial(device, 1000000, timeout=0.05) as port:
        client = boot.BootClient(ServoPort(port, 2, ax12_flash.ANSWER_TIMEOUT_S), retries=3)
        info = ax12_flash.enter_bootloader(client, 1000000, boot)
        pages = image.pages(info.page_bytes)
        client.begin(len(image.data), image.crc)
        count = len(pages) if cut[0] == "end" else cut[1]
        for address, data in pages[:count]:
            client.page(address, data, ax12_app_image.crc16(data))
        if cut[0] == "end":
            client.end()
        return len(pages)


def cut_points():
    """Where the kill comes: after BEGIN, after every page of the ax12a image, between END and
    GO (its page count read from the built HEX; none while it is not built)."""
    try:
        pages = len(ax12_app_image.load(HEX["ax12a"]).pages(128))
    except Exception:  # not built: the tests skip (needs_bootloader)
        pages = 0
    return [("pages", k) for k in range(pages + 1)] + [("end",)]


@needs_bootloader
@pytest.mark.parametrize("plan", cut_points(), ids=lambda plan: "after END" if plan[0] == "end" else
                         "after BEGIN" if plan[1] == 0 else f"after page {plan[1]}")
def test_an_update_cut_by_a_kill_leaves_a_servo_that_takes_a_new_one(serve, plan):
    emu = serve()
    partial_update(emu.device, "ax12a", plan)
    emu.kill(signal.SIGKILL)

    emu = serve()
    answer = exchange(emu.device, 2, boot.INFO)
    assert answer is not None, "the servo answers after the cut"
    if plan[0] == "pages":
        info = boot.parse_info(answer.params)
        assert info is not None, f"a bootloader answers INFO: {answer}"
        assert not info.state & boot.STATE_APP_VALID, "the application is not valid"
    else:
        assert answer.code & boot.ERR_INSTRUCTION and not answer.params, "the new application runs"
        assert_runs(emu.device, 2, "ax12a")
    for other in (1, 3):
        assert_runs(emu.device, other, "ax12")

    run = flash(emu.device, "ax12")
    assert run.returncode == 0, run.stdout + run.stderr
    assert_runs(emu.device, 2, "ax12")


@pytest.mark.parametrize("which", ["flipped data byte", "truncated"])
def test_a_bad_file_sends_nothing(serve, state_dir, which):
    log = state_dir / "bus.csv"
    emu = serve("--log-bus", str(log))
    lines = open(HEX["ax12a"]).read().splitlines()
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


@needs_bootloader
@pytest.mark.parametrize("which", sorted(REFUSED_HEX))
def test_a_refused_file_leaves_the_servo_answering_as_its_application(serve, state_dir, which):
    from dynamixel_sdk import COMM_SUCCESS, PacketHandler, PortHandler
    log = state_dir / "bus.csv"
    emu = serve("--log-bus", str(log))
    run = flash(emu.device, None, path=REFUSED_HEX[which])
    assert run.returncode == 2, run.stdout + run.stderr
    assert "Traceback" not in run.stderr and len(run.stderr.strip().splitlines()) == 1, run.stderr
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
    asked_in = [row for row in bus_rows(log) if row["sender"] == "client" and row["kind"] == "instruction"
                and int(row["raw"].split()[4], 16) == boot.BOOT]
    assert asked_in == [], "the servo was never asked into its bootloader"


@needs_bootloader
def test_the_emulator_killed_mid_update_ends_the_command_in_one_line_and_exit_1(serve):
    emu = serve()
    proc = subprocess.Popen([FRONT_DOOR, "flash", "--build", BUILD, "--port", emu.device, "--id", "2", HEX["ax12a"]],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
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
