# SPDX-License-Identifier: GPL-3.0-or-later
"""ax12-emu serve with the plant (docs/emulator.md "The plant", docs/control.md): the world
options reach the servo (supply, ambient, angle, load), a goal write moves the output, and bad
world values are one-line errors. Raw Protocol 1.0 packets through pyserial, --fast."""
import subprocess
import time

import pytest
import serial

import ax12_table as T
from ax12_packets import instruction_packet as packet, parse
from ax12_servo_port import transact
from conftest import EMU


def read(port, addr):
    """The item at addr of servo 1, whole (one or two bytes)."""
    n = T.BY_ADDR[addr].size
    reply = transact(port, packet(1, T.INST_READ, [addr, n]), 6 + n)
    status = parse(reply)
    assert status and status.ident == 1 and len(status.params) == n, reply.hex()
    return int.from_bytes(bytes(status.params), "little")


def write(port, addr, *data):
    assert len(transact(port, packet(1, T.INST_WRITE, [addr, *data]), 6)) == 6


def test_the_world_options_reach_the_servo(emulator, tmp_path):
    emu = emulator("--fast", "--state-dir", str(tmp_path), "--supply", "12", "--ambient", "40",
                   "--angle", "60")
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert read(port, T.PRESENT_VOLTAGE) == 120       # V x 10 (0.1 ohm, 35 mA)
        assert 40 <= read(port, T.PRESENT_TEMPERATURE) <= 41
        assert abs(read(port, T.PRESENT_POSITION) - 205) <= 1  # 60 deg = count 204.8


def test_a_goal_write_moves_the_output(emulator, tmp_path):
    emu = emulator("--fast", "--state-dir", str(tmp_path))
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        write(port, T.TORQUE_ENABLE, 1)
        write(port, T.GOAL_POSITION, 700 & 0xFF, 700 >> 8)
        deadline = time.monotonic() + 20
        while abs(read(port, T.PRESENT_POSITION) - 700) > 3 or read(port, T.MOVING):
            assert time.monotonic() < deadline
            time.sleep(0.01)


def test_a_load_arm_pulls_a_limp_output_down(emulator, tmp_path):
    # Torque off: the arm (horizontal at 150 deg) swings down toward 60 deg.
    emu = emulator("--fast", "--state-dir", str(tmp_path), "--load-arm", "0.2,0.1")
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        deadline = time.monotonic() + 20
        while read(port, T.PRESENT_POSITION) > 400:
            assert time.monotonic() < deadline
            time.sleep(0.01)


@pytest.mark.parametrize("args", [["--supply", "50"], ["--supply", "x"], ["--ambient", "-100"],
                                  ["--load-torque", "11"], ["--load-spring", "1,2,3"],
                                  ["--load-arm", "1"], ["--angle", "400"],
                                  ["--load-torque", "1", "--load-arm", "1,0.1"]])
def test_bad_world_values_are_one_line_errors(tmp_path, args):
    proc = subprocess.run([EMU, "serve", "--state-dir", str(tmp_path)] + args, capture_output=True,
                          text=True, timeout=10)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr


def test_help_lists_the_world_options():
    out = subprocess.run([EMU, "serve", "--help"], capture_output=True, text=True, timeout=10).stdout
    for option in ("--supply", "--ambient", "--angle", "--load-torque", "--load-spring", "--load-arm"):
        assert option in out
