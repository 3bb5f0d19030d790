# SPDX-License-Identifier: GPL-3.0-or-later
"""ax12-emu serve as a program: settings across SIGTERM and SIGKILL, clean shutdown, the --ids list,
--link, and one-line errors for bad input. Raw Protocol 1.0 packets through pyserial."""
import os
import subprocess
import time

import pytest
import serial

import ax12_table as T
from ax12_packets import instruction_packet as packet, parse, status_packet
from ax12_servo_port import transact
from conftest import EMU, FIRMWARE_DIR

PING_REPLY = {ident: status_packet(ident, 0) for ident in range(254)}


def read_byte(port, ident, addr):
    reply = transact(port, packet(ident, T.INST_READ, [addr, 1]), 7)
    status = parse(reply)
    assert status and status.checksum_ok, reply.hex()
    assert (status.ident, status.code, len(status.params)) == (ident, 0, 1), reply.hex()
    return status.params[0]


@pytest.mark.parametrize("mode", ["--fast", "--realtime"])
def test_a_write_answered_just_before_sigterm_is_stored_whole(emulator, tmp_path, mode):
    """Ctrl-C and SIGTERM run the servos until their EEPROM is quiet: a write answered (and so
    still being stored in the background) right before the signal survives."""
    state = tmp_path / "state"
    emu = emulator(mode, "--state-dir", str(state))
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert transact(port, packet(1, T.INST_PING), 6) == PING_REPLY[1]
        reply = transact(port, packet(1, T.INST_WRITE, [T.RETURN_DELAY_TIME, 37, 0x10, 0x00, 0xF0, 0x02]), 6)
        emu.proc.send_signal(15)
        assert reply == PING_REPLY[1]
    assert emu.proc.wait(timeout=10) == 0
    emu = emulator(mode, "--state-dir", str(state))
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert read_byte(port, 1, T.RETURN_DELAY_TIME) == 37
        assert read_byte(port, 1, T.CCW_ANGLE_LIMIT + 1) == 0x02


# Two complete settings of addresses 3..9 (ID, Baud Rate, Return Delay Time, both angle
# limits) the kill test writes in turn: (ID, baud register, the 7 bytes).
SETTINGS = [
    (1, 1, [1, 1, 250, 0x00, 0x00, 0xFF, 0x03]),
    (7, 3, [7, 3, 20, 0x20, 0x01, 0x80, 0x02]),
]


def bps(baud_register):
    return 2000000 // (baud_register + 1)


def settings_answered(device, ident, baud_register):
    """Addresses 0..23 as the servo at (ident, baud) answers them, or None when silent."""
    with serial.Serial(device, bps(baud_register), timeout=0.3) as port:
        reply = transact(port, packet(ident, T.INST_READ, [0, 24]), 30, timeout_s=0.3)
    status = parse(reply)
    if not status or not status.checksum_ok or status.ident != ident:
        return None
    return bytes(status.params)


def test_sigkill_at_random_moments_of_eeprom_writes_boots_the_old_or_the_new_settings(emulator, tmp_path):
    """SIGKILL (a power cut) at a random moment of a 7-byte EEPROM write that moves the servo
    to another ID and baud, then a restart: the servo answers at the old ID and baud with
    every old value, or at the new ones with every new value (docs/policy.md "Settings")."""
    import random
    rng = random.Random(20261125)
    state = tmp_path / "state"
    current = 0
    outcomes = {"old": 0, "new": 0}
    for attempt in range(16):
        emu = emulator("--state-dir", str(state))
        ident, baud, _ = SETTINGS[current]
        target = 1 - current
        with serial.Serial(emu.device, bps(baud), timeout=1.0) as port:
            assert transact(port, packet(ident, T.INST_PING), 6) == PING_REPLY[ident], attempt
            port.write(packet(ident, T.INST_WRITE, [T.ID] + SETTINGS[target][2]))
            time.sleep(rng.uniform(0.0, 0.045))  # the store takes about 34 ms after the reply
            os.kill(emu.proc.pid, 9)
        emu.proc.wait(timeout=10)
        emu = emulator("--state-dir", str(state))
        old = settings_answered(emu.device, ident, baud)
        new = settings_answered(emu.device, SETTINGS[target][0], SETTINGS[target][1])
        assert (old is None) != (new is None), f"attempt {attempt}: answered at both or neither"
        got = old if old is not None else new
        want = SETTINGS[current][2] if old is not None else SETTINGS[target][2]
        assert list(got[3:10]) == want, f"attempt {attempt}: a mix: {got.hex()}"
        outcomes["old" if old is not None else "new"] += 1
        current = current if old is not None else target
        emu.kill()
    assert outcomes["old"] > 0 and outcomes["new"] > 0, outcomes


def write_until_answered(port, params, tries=5):
    """A WRITE of settings to servo 1, sent again until its reply comes (on a loaded machine a
    request can wait in the pty past the timeout, docs/emulator.md "pty limit")."""
    for _ in range(tries):
        if transact(port, packet(1, T.INST_WRITE, params), 6, timeout_s=2.0) == PING_REPLY[1]:
            return
    raise AssertionError(f"no reply to a WRITE of {params} in {tries} tries")


def rdt_writes_logged(log_path):
    """From a --log-bus CSV cut by a SIGKILL: the simulated end (us) of each Return Delay Time
    WRITE's reply, in order, and the simulated time of the last row logged."""
    import csv
    import io
    with open(log_path, newline="") as f:
        text = f.read()
    # Only whole lines: the kill can cut the last one anywhere, even inside a number.
    whole = text[: text.rfind("\n") + 1]
    replies, last_us, waiting = [], 0.0, False
    for row in csv.DictReader(io.StringIO(whole)):
        if not row["end_us"] or row["params"] is None:
            break  # a malformed row (a whole line with fields missing): the log ends there
        last_us = float(row["end_us"])
        params = row["params"].split()
        if row["sender"] == "client":
            waiting = row["code_name"] == "WRITE" and params[:1] == ["05"]
        elif waiting:
            replies.append(last_us)
            waiting = False
    return replies, last_us


def test_a_stream_of_eeprom_writes_then_sigkill_keeps_the_writes_answered_before_it(emulator, tmp_path):
    """docs/policy.md "Settings": CW Angle Limit 100 stored, CW 200 answered, then WRITEs of
    Return Delay Time with a new value each (1..254 in turn) every 2 ms or so, until a SIGKILL
    (a power cut) at a random moment 1.5-2 s on, three times. After a restart the servo answers
    CW 200 (written seconds before the kill) and the Return Delay Time of a write answered at
    most 100 ms of simulated time before the last bus traffic the --log-bus file kept, or of
    one after it (the simulated times make the check independent of the machine's load)."""
    import random
    rng = random.Random(20261128)
    for attempt in range(3):
        state = tmp_path / f"state{attempt}"
        log = tmp_path / f"bus{attempt}.csv"
        emu = emulator("--state-dir", str(state), "--log-bus", str(log))
        sent = []  # Return Delay Time of each stream WRITE, in order
        answers = 0
        with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
            write_until_answered(port, [T.CW_ANGLE_LIMIT, 100, 0])
            time.sleep(0.3)
            write_until_answered(port, [T.CW_ANGLE_LIMIT, 200, 0])
            start = time.monotonic()
            kill_after = rng.uniform(1.5, 2.0)
            while time.monotonic() - start < kill_after:
                sent.append(len(sent) % 254 + 1)
                answers += transact(port, packet(1, T.INST_WRITE, [T.RETURN_DELAY_TIME, sent[-1]]), 6) == PING_REPLY[1]
                time.sleep(0.002)
            os.kill(emu.proc.pid, 9)
        emu.proc.wait(timeout=10)
        assert answers >= 20, f"attempt {attempt}: {answers} writes answered, not a stream"
        emu = emulator("--state-dir", str(state))
        with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
            assert read_byte(port, 1, T.CW_ANGLE_LIMIT) == 200, f"attempt {attempt}: the CW write is lost"
            stored = read_byte(port, 1, T.RETURN_DELAY_TIME)
        emu.kill()
        replies, last_us = rdt_writes_logged(log)
        due = sum(1 for end_us in replies if end_us <= last_us - 100000.0)  # writes that must be in
        allowed = sent[max(due - 1, 0):]
        assert len(allowed) < 254, f"attempt {attempt}: {len(allowed)} writes to choose from: no check"
        assert stored in allowed, (f"attempt {attempt}: Return Delay Time {stored}, but write {due} of {len(sent)} "
                                   f"(value {sent[due - 1]}) was answered 100 ms before the last logged traffic")


def test_sigterm_exits_cleanly_and_removes_the_link(emulator, tmp_path):
    link = tmp_path / "ax12"
    emu = emulator("--fast", "--state-dir", str(tmp_path / "state"), "--link", str(link))
    assert os.path.islink(link) and os.readlink(link) == emu.device
    with serial.Serial(str(link), 1000000, timeout=1.0) as port:
        assert transact(port, packet(1, T.INST_PING), 6) == PING_REPLY[1]
        assert transact(port, packet(1, T.INST_WRITE, [T.ALARM_LED, 0x24]), 6) == PING_REPLY[1]
    assert emu.stop() == 0
    assert not os.path.lexists(link)
    assert (tmp_path / "state" / "servo-1.eeprom").stat().st_size == 512
    emu = emulator("--fast", "--state-dir", str(tmp_path / "state"))
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert read_byte(port, 1, T.ALARM_LED) == 0x24


def test_every_listed_id_is_its_own_servo(emulator, tmp_path):
    emu = emulator("--fast", "--ids", "1-3,7,10", "--state-dir", str(tmp_path))
    with serial.Serial(emu.device, 1000000, timeout=0.3) as port:
        for ident in (1, 2, 3, 7, 10):
            assert transact(port, packet(ident, T.INST_PING), 6) == PING_REPLY[ident]
        assert transact(port, packet(4, T.INST_PING), 6, timeout_s=0.1) == b""
    assert sorted(p.name for p in tmp_path.glob("*.eeprom")) == sorted(
        f"servo-{i}.eeprom" for i in (1, 2, 3, 7, 10))
    assert sorted(p.name for p in tmp_path.glob("*.lock")) == sorted(
        f"servo-{i}.eeprom.lock" for i in (1, 2, 3, 7, 10))


@pytest.mark.parametrize("option", [["--baud", "57600"], ["--baud-register", "34"]])
def test_fresh_servos_start_at_the_baud_asked_for(emulator, tmp_path, option):
    """--baud in bit/s as a client sets it (57600: register 34, 57143 bit/s, 0.8 % off), or the
    Baud Rate register's value itself."""
    emu = emulator("--fast", *option, "--state-dir", str(tmp_path))
    with serial.Serial(emu.device, 57600, timeout=0.5) as port:
        assert transact(port, packet(1, T.INST_PING), 6) == PING_REPLY[1]
        assert transact(port, packet(1, T.INST_READ, [T.BAUD_RATE, 1]), 7)[5] == 34
    with serial.Serial(emu.device, 1000000, timeout=0.2) as port:
        assert transact(port, packet(1, T.INST_PING), 6, timeout_s=0.2) != PING_REPLY[1]


def test_bit_error_rate_corrupts_some_replies_and_the_stats_count_it(emulator, tmp_path):
    emu = emulator("--fast", "--state-dir", str(tmp_path), "--bit-error-rate", "0.01", "--seed", "7", "--stats")
    outcomes = {"clean": 0, "not clean": 0}
    with serial.Serial(emu.device, 1000000, timeout=0.05) as port:
        for _ in range(100):
            reply = transact(port, packet(1, T.INST_PING), 6, timeout_s=0.05)
            outcomes["clean" if reply == PING_REPLY[1] else "not clean"] += 1
    assert emu.stop() == 0
    # About 10 % of bytes corrupted: most 12-byte exchanges survive, many do not.
    assert outcomes["clean"] > 20 and outcomes["not clean"] > 5, outcomes
    stats = emu.proc.stderr.read().decode()
    assert "bytes corrupted" in stats, stats


def test_help_exits_zero():
    out = subprocess.run([EMU, "serve", "--help"], capture_output=True, text=True, timeout=10)
    assert out.returncode == 0
    assert "--ids" in out.stdout and "--state-dir" in out.stdout


@pytest.mark.parametrize("args, names", [
    (["--ids", "300"], "300"),
    (["--ids", "1,x"], "x"),
    (["--ids", "254"], "254"),
    (["--bogus"], "--bogus"),
    (["--baud", "255"], "--baud '255'"),
    (["--baud", "1"], "--baud '1'"),
    (["--baud", "3000000"], "--baud '3000000'"),
    (["--baud", "fast"], "--baud 'fast'"),
    (["--baud-register", "255"], "--baud-register '255'"),
    (["--baud", "57600", "--baud-register", "34"], "--baud and --baud-register"),
    (["--profile", "ax18"], "ax18"),
    (["--mcu", "attiny85"], "attiny85"),
    (["--elf", "/nonexistent/fw.elf"], "/nonexistent/fw.elf"),
    (["--state-dir", "/etc/passwd/state"], "/etc/passwd/state"),
    (["--ids"], "--ids"),
    (["--bit-error-rate", "1"], "--bit-error-rate '1'"),
    (["--bit-error-rate", "-0.1"], "-0.1"),
    (["--bit-error-rate", "noise"], "noise"),
    (["--seed", "-3"], "--seed '-3'"),
])
def test_bad_input_gives_one_line_naming_the_problem(args, names, tmp_path):
    full = [EMU, "serve", "--fast", "--firmware-dir", FIRMWARE_DIR]
    if "--state-dir" not in args:
        full += ["--state-dir", str(tmp_path)]
    started = time.monotonic()
    out = subprocess.run(full + args, capture_output=True, text=True, timeout=20)
    assert out.returncode != 0
    assert out.stdout == ""
    lines = out.stderr.splitlines()
    assert len(lines) == 1, out.stderr
    assert names in lines[0], lines[0]
    assert lines[0].endswith("(see scripts/ax12 serve --help)") or "--elf" in args or "--state-dir" in args, lines[0]
    assert time.monotonic() - started < 10


# --- the emulator's own edges (docs/emulator.md "State files") ---------------------------------

def run_serve(args, tmp_path, timeout=20):
    full = [EMU, "serve", "--fast", "--firmware-dir", FIRMWARE_DIR]
    if "--state-dir" not in args:
        full += ["--state-dir", str(tmp_path)]
    return subprocess.run(full + list(args), capture_output=True, text=True, timeout=timeout)


def test_a_non_avr_elf_is_refused_with_one_line(tmp_path):
    out = run_serve(["--elf", "/bin/sh"], tmp_path)
    assert out.returncode != 0 and out.stdout == ""
    assert out.stderr.splitlines() == ["ax12-emu: /bin/sh is not an AVR firmware ELF"], out.stderr


def test_an_elf_of_another_mcu_is_refused_naming_the_right_one(tmp_path):
    elf = os.path.join(FIRMWARE_DIR, "ax12-ax12-atmega88.elf")
    out = run_serve(["--elf", elf, "--mcu", "atmega328p"], tmp_path)
    assert out.returncode != 0 and out.stdout == ""
    lines = out.stderr.splitlines()
    assert len(lines) == 1 and "built for the atmega88, not the atmega328p" in lines[0], out.stderr


def test_a_fifo_as_state_file_is_refused_at_once(tmp_path):
    os.mkfifo(tmp_path / "servo-1.eeprom")
    started = time.monotonic()
    out = run_serve([], tmp_path)
    assert out.returncode != 0 and out.stdout == ""
    lines = out.stderr.splitlines()
    assert len(lines) == 1 and "servo-1.eeprom is not a regular file" in lines[0], out.stderr
    assert time.monotonic() - started < 10


@pytest.mark.parametrize("kind", ["garbage", "truncated", "old format"])
def test_a_bad_state_file_is_kept_aside_with_a_warning_and_the_servo_boots_as_its_firmware_decides(
        emulator, tmp_path, kind):
    state = tmp_path / "state"
    emu = emulator("--state-dir", str(state), "--ids", "4")
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert transact(port, packet(4, T.INST_WRITE, [T.RETURN_DELAY_TIME, 37]), 6) == PING_REPLY[4]
    assert emu.stop() == 0
    path = state / "servo-4.eeprom"
    good = path.read_bytes()
    if kind == "garbage":
        bad = bytes((i * 37 + 11) & 0xFF for i in range(len(good)))
    elif kind == "truncated":
        bad = good[:20]                       # cut inside the first settings slot
    else:                                     # format 1: version 1, the table, a CRC-8 (here 0)
        bad = bytes([1]) + good[1:25] + bytes([0]) + b"\xff" * (len(good) - 26)
    path.write_bytes(bad)
    emu = emulator("--state-dir", str(state), "--ids", "4")
    warning = emu.proc.stderr.readline().decode()
    assert "warning: servo 4:" in warning and str(path) in warning and "kept as" in warning, warning
    aside = state / "servo-4.eeprom.invalid-1"
    assert aside.read_bytes() == bad          # kept, not overwritten
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert read_byte(port, 1, T.RETURN_DELAY_TIME) == 250   # factory defaults: ID 1
    assert emu.stop() == 0
    emu = emulator("--state-dir", str(state), "--ids", "4")   # the defaults were stored
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert read_byte(port, 1, T.ID) == 1


def test_a_second_emulator_on_a_servo_in_use_is_refused_naming_the_first(emulator, tmp_path):
    state = tmp_path / "state"
    first = emulator("--state-dir", str(state), "--ids", "1,2")
    out = run_serve(["--state-dir", str(state), "--ids", "2"], tmp_path)
    assert out.returncode != 0 and out.stdout == ""
    lines = out.stderr.splitlines()
    assert len(lines) == 1 and "servo-2.eeprom is in use by another ax12-emu" in lines[0], out.stderr
    assert f"pid {first.proc.pid}" in lines[0], lines[0]
    other = emulator("--state-dir", str(state), "--ids", "3")   # another servo of the same folder
    with serial.Serial(other.device, 1000000, timeout=1.0) as port:
        assert transact(port, packet(3, T.INST_PING), 6) == PING_REPLY[3]
    first.kill()                                                # a SIGKILL frees it too
    again = emulator("--state-dir", str(state), "--ids", "2")
    with serial.Serial(again.device, 1000000, timeout=1.0) as port:
        assert transact(port, packet(2, T.INST_PING), 6) == PING_REPLY[2]


def start_up_lines(emu):
    """The emulator's stderr up to its start-up line (the one naming the servos and the pty)."""
    lines = []
    while not lines or " on /dev/pts/" not in lines[-1]:
        line = emu.proc.stderr.readline().decode()
        assert line, "stderr ended before the start-up line: %r" % lines
        lines.append(line.rstrip("\n"))
    return lines


def test_a_clean_stop_removes_the_lock_files(emulator, tmp_path):
    emu = emulator("--fast", "--ids", "1,2", "--state-dir", str(tmp_path))
    assert sorted(p.name for p in tmp_path.glob("*.lock")) == ["servo-1.eeprom.lock", "servo-2.eeprom.lock"]
    assert emu.stop() == 0
    assert list(tmp_path.glob("*.lock")) == []
    assert sorted(p.name for p in tmp_path.glob("*.eeprom")) == ["servo-1.eeprom", "servo-2.eeprom"]
    again = emulator("--fast", "--ids", "1,2", "--state-dir", str(tmp_path))  # and the next one runs
    with serial.Serial(again.device, 1000000, timeout=1.0) as port:
        assert transact(port, packet(2, T.INST_PING), 6) == PING_REPLY[2]


def test_the_start_up_line_names_a_servo_whose_saved_id_or_baud_is_not_its_slots(emulator, tmp_path):
    emu = emulator("--fast", "--ids", "1,2", "--state-dir", str(tmp_path))
    assert "answers at" not in start_up_lines(emu)[-1]
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        port.write(packet(1, T.INST_WRITE, [T.ID, 7]))
        time.sleep(0.2)
        port.write(packet(2, T.INST_WRITE, [T.BAUD_RATE, 34]))
        time.sleep(0.2)
    assert emu.stop() == 0
    emu = emulator("--fast", "--ids", "1,2", "--state-dir", str(tmp_path))
    line = start_up_lines(emu)[-1]
    assert line.endswith("; slot 1 answers at ID 7, slot 2 answers at 57143 bit/s (saved settings)"), line
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert transact(port, packet(7, T.INST_PING), 6) == PING_REPLY[7]


def test_settings_cut_in_their_store_are_named_once_at_start_and_the_older_ones_boot(emulator, tmp_path):
    """A state file whose newer settings slot fails its check (here: one byte of the slot a WRITE
    stored into changed, as a store cut by a power loss leaves it): one warning at start naming
    the servo, the file and what it means; the servo boots the settings stored before."""
    emu = emulator("--fast", "--ids", "3", "--state-dir", str(tmp_path))
    assert emu.stop() == 0
    path = tmp_path / "servo-3.eeprom"
    before = path.read_bytes()
    emu = emulator("--fast", "--ids", "3", "--state-dir", str(tmp_path))
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert transact(port, packet(3, T.INST_WRITE, [T.RETURN_DELAY_TIME, 37]), 6) == PING_REPLY[3]
    assert emu.stop() == 0
    after = bytearray(path.read_bytes())
    stored = [i for i in range(len(after)) if after[i] != before[i]]
    assert stored, "the write reached the state file"
    after[stored[0]] ^= 0x40  # the slot written last no longer passes its check
    path.write_bytes(bytes(after))
    emu = emulator("--fast", "--ids", "3", "--state-dir", str(tmp_path))
    lines = start_up_lines(emu)
    warnings = [line for line in lines if "fail their check" in line]
    assert warnings == ["ax12-emu: warning: servo 3: the newer settings in %s fail their check (a store cut by a "
                        "power loss or a kill, or a damaged file): it boots the settings stored before them" % path], lines
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert read_byte(port, 3, T.RETURN_DELAY_TIME) == 250
    assert emu.stop() == 0
    assert not (tmp_path / "servo-3.eeprom.invalid-1").exists(), "a valid image is not set aside"
