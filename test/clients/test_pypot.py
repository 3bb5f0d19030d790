"""pypot 5.0.2 (`pypot.dynamixel.DxlIO`), unmodified, against emulated AX-12 servos.

pypot reads with READ_DATA, one servo at a time, and writes every setter with SYNC_WRITE to the
broadcast ID (no status packet), also for a single servo.
"""
import time

import pytest
import pypot.dynamixel
from pypot.dynamixel.conversion import degree_to_dxl

import ax12_policy as P

BUS_IDS = "1-18"
ALL = P.parse_ids(BUS_IDS)
DEG = 300.0 / 1023          # one position unit in degrees
DPS = 0.111 * 6             # one speed unit in degrees per second


def open_io(path):
    return pypot.dynamixel.DxlIO(path, baudrate=1000000, timeout=0.05)


@pytest.fixture
def bus18(emulators):
    emu = emulators(ids=BUS_IDS)
    with open_io(emu.path) as io:
        yield io


@pytest.fixture
def io1(emulators):
    emu = emulators(ids="1")
    with open_io(emu.path) as io:
        yield io


def settle():
    time.sleep(0.02)   # SYNC_WRITE has no status packet: let the servos take it


def test_scan_finds_every_id_on_the_bus(bus18):
    assert bus18.scan(range(25)) == ALL


def test_get_model_reads_ax12_for_every_servo(bus18):
    assert bus18.get_model(ALL) == ("AX-12",) * len(ALL)


def test_get_control_table_reads_the_whole_table(io1):
    (table,) = io1.get_control_table([1])
    assert table["model"] == "AX-12"
    assert table["firmware"] == io1.get_firmware([1])[0]
    assert table["status return level"] == "always"
    assert table["compliance slope"] == (32, 32)
    assert table["punch"] == 32


def test_present_and_goal_position_in_degrees(io1):
    (pos,) = io1.get_present_position([1])
    assert -150.0 <= pos <= 150.0
    io1.set_goal_position({1: 30.0})
    settle()
    assert io1.get_goal_position([1])[0] == pytest.approx(30.0, abs=DEG)
    assert io1.get_goal_position([1], convert=False)[0] == degree_to_dxl(30.0, "AX-12")


def test_set_goal_position_for_several_ids_writes_each_servos_goal(bus18):
    goals = {i: -120.0 + 13.0 * i for i in ALL}
    before = bus18.get_goal_position(ALL, convert=False)
    bus18.set_goal_position(goals)           # one SYNC_WRITE for all 18
    settle()
    after = bus18.get_goal_position(ALL)
    for i, got in zip(ALL, after):
        assert got == pytest.approx(goals[i], abs=DEG), f"id {i}"
    changed = [i for i, a, b in zip(ALL, bus18.get_goal_position(ALL, convert=False), before)
               if a != b]
    assert changed == ALL


def test_moving_speed(bus18):
    speeds = {i: 20.0 * i for i in ALL}
    bus18.set_moving_speed(speeds)
    settle()
    for i, got in zip(ALL, bus18.get_moving_speed(ALL)):
        assert got == pytest.approx(speeds[i], abs=DPS), f"id {i}"


def test_compliance_margins_and_slopes(io1):
    assert io1.get_compliance_margin([1]) == ((0, 0),)
    io1.set_compliance_margin({1: (4, 8)})
    settle()  # setters apart: the pty flush race is the subject of its own test (PTY_FLUSH_RACE)
    io1.set_compliance_slope({1: (64, 128)})
    settle()
    assert io1.get_compliance_margin([1]) == ((4, 8),)
    assert io1.get_compliance_slope([1]) == ((64, 128),)


def test_angle_limits(io1):
    assert io1.get_angle_limit([1]) == ((-150.0, 150.0),)
    io1.set_angle_limit({1: (-90.0, 90.0)})
    settle()
    cw, ccw = io1.get_angle_limit([1])[0]
    assert cw == pytest.approx(-90.0, abs=DEG) and ccw == pytest.approx(90.0, abs=DEG)
    assert io1.get_angle_limit([1], convert=False) == ((degree_to_dxl(-90.0, "AX-12"),
                                                        degree_to_dxl(90.0, "AX-12")),)
    io1.set_wheel_mode([1])
    settle()
    assert io1.get_angle_limit([1], convert=False) == ((0, 0),)
    io1.set_joint_mode([1])
    settle()
    assert io1.get_angle_limit([1], convert=False) == ((0, 1023),)


# pypot flushes its port (tcflush TCIOFLUSH) before every packet. On a Linux pty a write sits
# in the kernel's flip buffer for a few to some tens of microseconds before any reader can see
# it, and TCOFLUSH on the slave empties that buffer: a packet written just before the next
# call's flush can vanish before it reaches the emulator. Measured on a bare pty without the
# emulator: 20-50 % of such writes lost (docs/emulator.md, "pty limit"). A USB adapter has sent
# the bytes by then, so the back-to-back test keeps its assertions and is expected to fail on a
# pty until the device is not a pty (strict=False: it passes when the race is won). Other tests
# keep their setters 20 ms apart so that they test their own subject.
PTY_FLUSH_RACE = pytest.mark.xfail(
    strict=False, reason="Linux pty: tcflush(TCOFLUSH) right after write() drops the packet (docs/emulator.md)")


def test_torque_led_and_torque_limit(io1):
    assert io1.is_torque_enabled([1]) == (False,)
    io1.enable_torque([1])
    settle()  # setters apart: the pty flush race is the subject of its own test (PTY_FLUSH_RACE)
    io1.switch_led_on([1])
    settle()
    io1.set_torque_limit({1: 50.0})
    settle()
    assert io1.is_torque_enabled([1]) == (True,)
    assert io1.is_led_on([1]) == (True,)
    assert io1.get_torque_limit([1]) == (pytest.approx(50.0, abs=0.1),)
    io1.disable_torque([1])
    settle()
    io1.switch_led_off([1])
    settle()
    assert io1.is_torque_enabled([1]) == (False,)
    assert io1.is_led_on([1]) == (False,)


def test_present_readings_are_plausible(io1):
    (volts,) = io1.get_present_voltage([1])
    (temp,) = io1.get_present_temperature([1])
    assert 5.0 <= volts <= 25.0
    assert 0.0 <= temp <= 85.0
    assert io1.is_moving([1]) == (False,)
    pos, speed, load = io1.get_present_position_speed_load([1])[0]
    assert -150.0 <= pos <= 150.0


def test_change_id(emulators):
    with open_io(emulators(ids="1-3").path) as io:
        io.change_id({2: 12})
        settle()
        assert io.scan(range(15)) == [1, 3, 12]


def test_change_baudrate_then_reopen(emulators):
    path = emulators(ids="1-2").path
    with open_io(path) as io:
        io.change_baudrate({1: 57600, 2: 57600})
        settle()
        assert io.scan(range(4)) == []
    with pypot.dynamixel.DxlIO(path, baudrate=57600, timeout=0.05) as io:
        assert io.scan(range(4)) == [1, 2]
        assert io.get_model([1, 2]) == ("AX-12", "AX-12")


@PTY_FLUSH_RACE
def test_back_to_back_sync_writes_all_take_effect(io1):
    """pypot flushes input and output (tcflush) before every packet and does not wait after a
    SYNC_WRITE, so its next call follows the previous packet within microseconds. A USB
    adapter has sent the bytes by then; the emulated bus must have taken them too."""
    lost = []
    for k in range(40):
        goal, speed = 300 + 10 * k, 1 + k
        io1.set_goal_position({1: goal}, convert=False)
        io1.set_moving_speed({1: speed}, convert=False)     # right behind the first packet
        settle()
        got = (io1.get_goal_position([1], convert=False)[0],
               io1.get_moving_speed([1], convert=False)[0])
        if got != (goal, speed):
            lost.append((k, (goal, speed), got))
    assert not lost, f"{len(lost)}/40 rounds lost a SYNC_WRITE: {lost[:5]}"


def test_status_return_level(io1):
    assert io1.get_status_return_level([1]) == ("always",)
    io1.set_status_return_level({1: "read"})
    settle()
    assert io1.get_status_return_level([1]) == ("read",)
    io1.set_status_return_level({1: "never"})
    settle()
    # READ goes unanswered at level 0; pypot then pings, which is still answered.
    assert io1.get_status_return_level([1]) == ("never",)
    io1.set_status_return_level({1: "always"})      # SYNC_WRITE needs no reply
    settle()
    assert io1.get_status_return_level([1]) == ("always",)


def test_factory_reset_brings_the_servo_back_at_id_1(emulators):
    with open_io(emulators(ids="5").path) as io:
        io.set_return_delay_time({5: 100})
        settle()
        assert io.get_return_delay_time([5]) == (100,)
        io.factory_reset()          # RESET to IDs 0, 1, ... until one answers
        settle()
        assert io.scan(range(8)) == [1]
        assert io.get_return_delay_time([1]) == (500,)


def _wait_for_motion(io, ids, goals_dxl, timeout_s=3.0):
    """Poll Present Position and Moving; returns (moved_at_all, reached)."""
    start = io.get_present_position(ids, convert=False)
    moved = False
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        pos = io.get_present_position(ids, convert=False)
        moving = io.is_moving(ids)
        moved = moved or any(moving) or any(abs(a - b) > 2 for a, b in zip(pos, start))
        if all(abs(p - goals_dxl[i]) <= 3 for p, i in zip(pos, ids)) and not any(moving):
            return moved, True
        time.sleep(0.05)
    return moved, False


def test_sync_written_goals_are_reached(bus18):
    """With torque on, every servo travels to its SYNC_WRITE goal. Skipped (never silently
    passed) only when no servo's Present Position or Moving changes at all, i.e. the emulator
    has no motion yet."""
    ids = ALL[:6]
    present = bus18.get_present_position(ids, convert=False)
    goals = {i: (p + 200 if p < 512 else p - 200) for i, p in zip(ids, present)}
    bus18.enable_torque(ids)
    settle()  # setters apart: the pty flush race is the subject of its own test (PTY_FLUSH_RACE)
    bus18.set_goal_position(goals, convert=False)
    moved, reached = _wait_for_motion(bus18, ids, goals)
    if not moved:
        pytest.skip("no servo's Present Position or Moving changed within 3 s of a goal "
                    "with torque on: the emulator does not move the output yet")
    assert reached, (f"goals {goals}, present "
                     f"{dict(zip(ids, bus18.get_present_position(ids, convert=False)))}")
