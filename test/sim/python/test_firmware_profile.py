# SPDX-License-Identifier: GPL-3.0-or-later
"""scripts/firmware_profile: the cycle profile of the real ELF in simavr (ax12-bench profile)
accounts for every awake cycle, and shows the traffic where it is paid."""
import json
import os
import subprocess
import sys

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
CPU_HZ = 16_000_000


@pytest.fixture(scope="module")
def profile():
    bench = os.environ.get("AX12_BENCH")
    elf = os.path.join(os.environ.get("AX12_FIRMWARE_DIR", ""), "ax12-ax12-atmega88.elf")
    if not bench or not os.path.exists(elf):
        if os.environ.get("AX12_FIRMWARE_REQUIRED") == "1":
            pytest.fail("ax12-bench or the firmware ELF is missing")
        pytest.skip("no firmware ELF (no avr-gcc)")
    out = subprocess.run([sys.executable, os.path.join(REPO, "scripts", "firmware_profile"), "--json", "--bench",
                          bench, "--elf", elf, "--servos", "3", "--seconds", "0.1"],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def rx_interrupt(phase):
    """The USART_RX vector and its paths placed before it (uart_rx.S)."""
    return sum(c for name, c in phase.items() if name.endswith("__vector_18"))


def test_every_awake_cycle_is_profiled(profile):
    for phase in ("holding", "loop"):
        assert profile[phase + "_awake_cycles"] > 0
        assert profile[phase + "_profiled_cycles"] == profile[phase + "_awake_cycles"]


def test_holding_costs_the_control_tick_only(profile):
    share = profile["holding_cycles_per_servo_s"] / CPU_HZ
    assert 0.03 < share < 0.10  # ax12-bench awake: 6.1 % holding
    assert rx_interrupt(profile["holding"]) == 0
    assert profile["holding"].get("__vector_12", 0) > 0  # TIMER1_COMPB, the 1 kHz tick


def test_the_client_loop_is_paid_in_the_rx_interrupt(profile):
    assert profile["loops_per_sim_s"] > 0
    assert profile["loop_cycles_per_servo_s"] > profile["holding_cycles_per_servo_s"]
    assert rx_interrupt(profile["loop"]) > 0.2 * profile["loop_cycles_per_servo_s"]
