"""pyax12 0.5.dev3, unmodified, against emulated AX-12 servos.

pyax12 writes a packet, sleeps 20 ms, then parses whatever has arrived as one status packet;
a status packet with any error bit set raises the matching pyax12.status_packet exception.
"""
import pytest
from pyax12.connection import Connection
from pyax12 import status_packet as sp

import ax12_policy as P
import ax12_table as T


@pytest.fixture
def conn(emulators):
    c = Connection(port=emulators(ids="1-3").path, baudrate=1000000)
    yield c
    c.close()


def test_ping(conn):
    assert conn.ping(1)
    assert conn.ping(3)
    assert not conn.ping(4)


def test_scan(conn):
    assert list(conn.scan(bytes(range(8)))) == [1, 2, 3]


def test_model_firmware_and_control_table(conn):
    assert conn.get_model_number(1) == 12
    assert conn.get_firmware_version(1) >= 0
    table = conn.dump_control_table(2)
    assert len(table) == T.TABLE_SIZE
    assert table[T.MODEL_NUMBER:T.MODEL_NUMBER + 2] == bytes([12, 0])
    assert table[T.ID] == 2
    assert table[T.RETURN_DELAY_TIME] == 250
    assert table[T.STATUS_RETURN_LEVEL] == 2


def test_read_data_and_write_data(conn):
    assert conn.read_data(1, T.LED, 1) == bytes([0])
    conn.write_data(1, T.LED, 1)
    assert conn.read_data(1, T.LED, 1) == bytes([1])
    assert conn.is_led_enabled(1)
    conn.write_data(1, T.PUNCH, bytes([0x40, 0x00]))
    assert conn.get_punch(1) == 64
    conn.write_data(1, T.CW_COMPLIANCE_MARGIN, (3, 5, 16, 64))  # margins and slopes, one packet
    assert conn.read_data(1, T.CW_COMPLIANCE_MARGIN, 4) == bytes([3, 5, 16, 64])


def test_present_position_and_goto(conn):
    pos = conn.get_present_position(1)
    assert 0 <= pos <= 1023
    assert abs(conn.get_goal_position(1) - pos) <= 2     # goal = present at power-up
    goal = 700 if pos < 512 else 300
    conn.goto(1, goal, speed=200)
    assert conn.get_goal_position(1) == goal
    assert conn.get_moving_speed(1) == 200
    conn.goto(2, 45, degrees=True)
    assert conn.get_goal_position(2) == pytest.approx(512 + 45 * 1023 / 300, abs=2)


def test_eeprom_setters(conn):
    conn.set_cw_angle_limit(3, 100)
    conn.set_ccw_angle_limit(3, 900)
    conn.set_return_delay_time(3, 100)      # microseconds: register 50
    assert conn.get_cw_angle_limit(3) == 100
    assert conn.get_ccw_angle_limit(3) == 900
    assert conn.read_data(3, T.RETURN_DELAY_TIME, 1) == bytes([50])


def test_out_of_range_write_raises_range_error(conn):
    with pytest.raises(sp.RangeError):
        conn.write_data(1, T.GOAL_POSITION, bytes([0x00, 0x04]))  # 1024
    assert conn.get_goal_position(1) <= 1023
    assert conn.ping(1)                                       # an event, not a condition


def test_goal_outside_angle_limits_raises_angle_limit_error(conn):
    conn.goto(2, 512)
    conn.set_cw_angle_limit(2, 200)
    with pytest.raises(sp.AngleLimitError):
        conn.goto(2, 100)
    # The goal is stored, and the condition stays in every status packet meanwhile.
    with pytest.raises(sp.AngleLimitError):
        conn.read_data(2, T.GOAL_POSITION, 2)
    conn.goto(2, 512)
    assert conn.get_goal_position(2) == 512


def test_id_change(conn):
    conn.set_id(3, 7)          # answered with the old ID 3
    assert conn.ping(7)
    assert not conn.ping(3)


def test_eeprom_writes_are_answered_within_pyax12s_20_ms_and_read_back_at_once(conn):
    """pyax12 reads the reply 20 ms after sending; a late reply would be taken as the reply to
    the next call. A write of the EEPROM area is answered at its Return Delay Time like any
    other and stored afterwards (docs/policy.md "Settings"), so a write of eight bytes, six of
    them changed (31 ms of EEPROM writes with the check and the sequence number), is answered
    in time and reads back at once."""
    settings = bytes([100, 55, 150, 0x20, 0x03, 2, 0x25, 0x25])   # addresses 11..18
    conn.write_data(1, T.HIGHEST_LIMIT_TEMP, settings)
    assert conn.read_data(1, T.HIGHEST_LIMIT_TEMP, len(settings)) == settings
    conn.write_data(1, T.RETURN_DELAY_TIME, bytes([20, 100, 0, 0x84, 0x03]))  # addresses 5..9
    assert conn.read_data(1, T.RETURN_DELAY_TIME, 5) == bytes([20, 100, 0, 0x84, 0x03])
