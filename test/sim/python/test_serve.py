# SPDX-License-Identifier: GPL-3.0-or-later
"""ax12-emu serve as a program: persistence across SIGKILL, clean shutdown, the --ids list,
--link, and one-line errors for bad input. Raw Protocol 1.0 packets through pyserial."""
import os
import subprocess
import time

import pytest
import serial

import ax12_table as T
from ax12_packets import instruction_packet as packet, parse, status_packet
from conftest import EMU, FIRMWARE_DIR

PING_REPLY = {ident: status_packet(ident, 0) for ident in range(254)}


def transact(port, request, reply_len, timeout=1.0):
    port.reset_input_buffer()
    port.write(request)
    port.timeout = timeout
    return port.read(reply_len)


def read_byte(port, ident, addr):
    reply = transact(port, packet(ident, T.INST_READ, [addr, 1]), 7)
    status = parse(reply)
    assert status and status.checksum_ok, reply.hex()
    assert (status.ident, status.code, len(status.params)) == (ident, 0, 1), reply.hex()
    return status.params[0]


@pytest.mark.parametrize("mode", ["--fast", "--realtime"])
def test_a_write_survives_sigkill_right_after_its_reply(emulator, tmp_path, mode):
    state = tmp_path / "state"
    emu = emulator(mode, "--state-dir", str(state))
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert transact(port, packet(1, T.INST_PING), 6) == PING_REPLY[1]
        reply = transact(port, packet(1, T.INST_WRITE, [T.RETURN_DELAY_TIME, 37]), 6)
        os.kill(emu.proc.pid, 9)  # at once: no clean shutdown
        assert reply == PING_REPLY[1]
    emu.proc.wait(timeout=10)
    emu = emulator(mode, "--state-dir", str(state))
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert read_byte(port, 1, T.RETURN_DELAY_TIME) == 37


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
        assert transact(port, packet(4, T.INST_PING), 6, timeout=0.1) == b""
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        f"servo-{i}.eeprom" for i in (1, 2, 3, 7, 10))


def test_fresh_servos_start_at_the_baud_asked_for(emulator, tmp_path):
    emu = emulator("--fast", "--baud", "34", "--state-dir", str(tmp_path))
    with serial.Serial(emu.device, 57600, timeout=0.5) as port:
        assert transact(port, packet(1, T.INST_PING), 6) == PING_REPLY[1]
    with serial.Serial(emu.device, 1000000, timeout=0.2) as port:
        assert transact(port, packet(1, T.INST_PING), 6, timeout=0.2) != PING_REPLY[1]


def test_bit_error_rate_corrupts_some_replies_and_the_stats_count_it(emulator, tmp_path):
    emu = emulator("--fast", "--state-dir", str(tmp_path), "--bit-error-rate", "0.01", "--seed", "7", "--stats")
    outcomes = {"clean": 0, "not clean": 0}
    with serial.Serial(emu.device, 1000000, timeout=0.05) as port:
        for _ in range(100):
            reply = transact(port, packet(1, T.INST_PING), 6, timeout=0.05)
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
    (["--baud", "255"], "255"),
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
    assert time.monotonic() - started < 10
