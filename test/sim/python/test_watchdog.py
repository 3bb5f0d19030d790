# SPDX-License-Identifier: GPL-3.0-or-later
"""The watchdog (docs/firmware.md "Watchdog"): firmware builds with a hang injected 1.5 s after
power-up (the main loop, the control tick, the receive path; AX12_INJECT_HANG), served by
ax12-emu. Each hang resets the MCU 250 ms later; the servo comes back with its settings
(EEPROM) and its RAM at power-up values, and answers again."""
import os
import time

import pytest
import serial

import ax12_table as T
from ax12_packets import instruction_packet as packet, parse, status_packet
from ax12_servo_port import transact

HANG_DIR = os.environ.get("AX12_HANG_DIR", "")
POLL_TIMEOUT_S = 0.05  # one poll of the timeline: silence for longer counts as no answer


def answers(port, ident):
    return transact(port, packet(ident, T.INST_PING), 6, POLL_TIMEOUT_S) == status_packet(ident, 0)


def read_byte(port, ident, addr):
    status = parse(transact(port, packet(ident, T.INST_READ, [addr, 1]), 7, timeout_s=0.5))
    assert status and status.checksum_ok and status.code == 0, status
    return status.params[0]


def led_answered(port, ident):
    """Register 25 (LED) as the servo answers it, or None when it does not answer."""
    status = parse(transact(port, packet(ident, T.INST_READ, [T.LED, 1]), 7, POLL_TIMEOUT_S))
    if not status or not status.checksum_ok or status.ident != ident:
        return None
    return status.params[0]


@pytest.mark.parametrize("hang", ["MAIN", "TICK", "RX"])
def test_a_hang_resets_the_servo_which_comes_back_with_its_settings(emulator, tmp_path, hang):
    """The hang starts 1.5 s after power-up; 250 ms later the watchdog resets the MCU, which
    a client sees as its RAM back at power-up values (LED 0 here) with its EEPROM settings
    (ID 5) kept. A hung main loop or receive path is also silent from the hang until the
    reset; a hung control tick still answers until then."""
    elf = os.path.join(HANG_DIR, hang, "ax12-ax12-atmega328p.elf")
    assert os.path.exists(elf), elf
    emu = emulator("--mcu", "atmega328p", "--elf", elf, "--state-dir", str(tmp_path / "state"))
    with serial.Serial(emu.device, 1000000, timeout=0.5) as port:
        boot = time.monotonic()
        assert answers(port, 1)
        assert transact(port, packet(1, T.INST_WRITE, [T.ID, 5]), 6, 0.5) == status_packet(1, 0)
        assert transact(port, packet(5, T.INST_WRITE, [T.TORQUE_ENABLE, 1, 1]), 6, 0.5) == status_packet(5, 0)
        timeline = []
        while time.monotonic() - boot < 3.0:
            timeline.append((time.monotonic() - boot, led_answered(port, 5)))
        reset_at = next((t for t, led in timeline if led == 0), None)
        assert reset_at is not None, f"{hang}: the servo was never reset (LED never read 0)"
        # 1.5 s to the hang, 0.25 s of watchdog, a margin for the wall clock against the
        # simulated one.
        assert 1.7 <= reset_at <= 2.4, f"{hang}: reset seen at {reset_at:.3f} s"
        silent = [t for t, led in timeline if led is None and t < reset_at]
        if hang in ("MAIN", "RX"):
            assert silent and silent[0] >= 1.4, f"{hang}: silent from {silent[:1]}"
            assert reset_at - silent[0] >= 0.2, f"{hang}: reset {reset_at - silent[0]:.3f} s after the hang"
        else:
            assert not [t for t in silent if t < 1.7], f"{hang}: silent before the reset: {silent[:3]}"
        assert read_byte(port, 5, T.ID) == 5
        assert read_byte(port, 5, T.TORQUE_ENABLE) == 0


def test_without_a_hang_the_servo_is_never_reset(emulator, tmp_path):
    """The product firmware under a steady load of packets for 3 s, EEPROM writes among them:
    never reset (its watchdog is fed all along), which --stats confirms."""
    emu = emulator("--state-dir", str(tmp_path / "state"), "--stats")
    with serial.Serial(emu.device, 1000000, timeout=0.5) as port:
        assert transact(port, packet(1, T.INST_WRITE, [T.LED, 1]), 6, 0.5) == status_packet(1, 0)
        start = time.monotonic()
        n = 0
        while time.monotonic() - start < 3.0:
            assert led_answered(port, 1) == 1, f"reset or silent at {time.monotonic() - start:.2f} s"
            n += 1
            if n % 50 == 0:
                assert transact(port, packet(1, T.INST_WRITE, [T.RETURN_DELAY_TIME, n % 200]), 6, 0.5) \
                    == status_packet(1, 0)
    assert emu.stop() == 0
    stats = emu.proc.stderr.read().decode()
    assert "watchdog resets 0" in stats, stats
