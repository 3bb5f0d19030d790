"""ROBOTIS DynamixelSDK 4.1.0 (Protocol 1.0), unmodified, against emulated AX-12 servos.

Every expectation comes from docs/policy.md.
"""
import time

import pytest
from dynamixel_sdk import (COMM_RX_TIMEOUT, COMM_SUCCESS, GroupSyncWrite, PacketHandler,
                           PortHandler)
from dynamixel_sdk.robotis_def import BROADCAST_ID, DXL_HIBYTE, DXL_LOBYTE

import ax12_policy as P
import ax12_table as T

BAUD_1M = 1_000_000


class Bus:
    """One SDK port + Protocol 1.0 packet handler, with the checks every test repeats."""

    def __init__(self, path, baud=BAUD_1M):
        self.port = PortHandler(path)
        assert self.port.openPort(), f"openPort({path}) failed"
        assert self.port.setBaudRate(baud), f"setBaudRate({baud}) refused"
        self.ph = PacketHandler(1.0)

    def close(self):
        self.port.closePort()

    def _check(self, what, result, error, want_error=0):
        assert result == COMM_SUCCESS, f"{what}: {self.ph.getTxRxResult(result)} ({result})"
        assert error == want_error, (f"{what}: error byte 0x{error:02x}, expected "
                                     f"0x{want_error:02x} {self.ph.getRxPacketError(error)}")

    def ping(self, dxl_id):
        model, result, error = self.ph.ping(self.port, dxl_id)
        self._check(f"ping({dxl_id})", result, error)
        return model

    def answers(self, dxl_id):
        _, result, _ = self.ph.ping(self.port, dxl_id)
        return result == COMM_SUCCESS

    def read(self, dxl_id, addr, size=None, want_error=0):
        size = size or P.BY_ADDR[addr].size
        fn = self.ph.read1ByteTxRx if size == 1 else self.ph.read2ByteTxRx
        value, result, error = fn(self.port, dxl_id, addr)
        self._check(f"read{size}(id {dxl_id}, addr {addr})", result, error, want_error)
        return value

    def write(self, dxl_id, addr, value, size=None, want_error=0):
        size = size or P.BY_ADDR[addr].size
        fn = self.ph.write1ByteTxRx if size == 1 else self.ph.write2ByteTxRx
        result, error = fn(self.port, dxl_id, addr, value)
        self._check(f"write{size}(id {dxl_id}, addr {addr}, {value})", result, error, want_error)

    def write_no_reply(self, dxl_id, addr, value, size=None):
        """WRITE without waiting for a status packet (Status Return Level < 2)."""
        size = size or P.BY_ADDR[addr].size
        fn = self.ph.write1ByteTxOnly if size == 1 else self.ph.write2ByteTxOnly
        assert fn(self.port, dxl_id, addr, value) == COMM_SUCCESS
        settle(self.port)

    def raw(self, dxl_id, instruction, params=()):
        """Any instruction through the SDK's own framing (txRxPacket); returns (result, error)."""
        pkt = [0, 0, dxl_id, len(params) + 2, instruction, *params, 0]
        rx, result, error = self.ph.txRxPacket(self.port, pkt)
        return rx, result, error


def settle(port, seconds=0.02):
    """Let any reply still on its way arrive, then drop it (the SDK would otherwise attribute
    a late status packet of the same ID to the next instruction)."""
    time.sleep(seconds)
    port.clearPort()


@pytest.fixture
def bus_factory():
    buses = []

    def make(path, baud=BAUD_1M):
        b = Bus(path, baud)
        buses.append(b)
        return b

    yield make
    for b in buses:
        b.close()


@pytest.fixture
def one(emulators, bus_factory):
    """One factory-fresh servo, ID 1, profile ax12."""
    emu = emulators(ids="1")
    return bus_factory(emu.path)


# ---------------------------------------------------------------------------------------------
# Ping and reading
# ---------------------------------------------------------------------------------------------

def test_ping_reports_model_number_12(one):
    assert one.ping(1) == 12


def test_ping_of_an_absent_id_times_out(one):
    model, result, error = one.ph.ping(one.port, 2)
    assert result == COMM_RX_TIMEOUT, one.ph.getTxRxResult(result)


@pytest.mark.parametrize("profile", ["ax12", "ax12a"])
def test_every_address_reads_its_factory_default(emulators, bus_factory, profile):
    bus = bus_factory(emulators(ids="1", profile=profile).path)
    for item in P.TABLE:
        want = P.default(item, profile)
        value = bus.read(1, item.addr)
        if want is not P.RUNTIME:
            assert value == want, f"{item.name} (addr {item.addr}) = {value}, default {want}"
    # Power-up: Goal Position = Present Position, Torque Limit = Max Torque.
    assert abs(bus.read(1, T.GOAL_POSITION) - bus.read(1, T.PRESENT_POSITION)) <= 2
    assert bus.read(1, T.TORQUE_LIMIT) == bus.read(1, T.MAX_TORQUE)
    assert 0 <= bus.read(1, T.PRESENT_POSITION) <= 1023


def test_every_address_reads_with_read1_and_read2(one):
    """READ 1 byte at 0..49 and 2 bytes at 0..48 all succeed with no error, and agree with one
    READ of the whole table (for the items that do not change on their own)."""
    table, result, error = one.ph.readTxRx(one.port, 1, 0, T.TABLE_SIZE)
    one._check(f"read(0, {T.TABLE_SIZE})", result, error)
    assert len(table) == T.TABLE_SIZE
    live = set(range(T.PRESENT_POSITION, T.PRESENT_TEMPERATURE + 1)) | {T.MOVING}
    for addr in range(0, T.TABLE_SIZE):
        v1 = one.read(1, addr, size=1)
        if addr not in live:
            assert v1 == table[addr], f"read1 addr {addr}: {v1} vs table {table[addr]}"
    for addr in range(0, T.TABLE_SIZE - 1):
        v2 = one.read(1, addr, size=2)
        if addr not in live and addr + 1 not in live:
            assert v2 == table[addr] | table[addr + 1] << 8, f"read2 addr {addr}"


def test_read_window_past_address_49_is_a_range_error_with_no_data(one):
    # The SDK's read2ByteTxRx would index a missing second byte; readTxRx shows the packet.
    data, result, error = one.ph.readTxRx(one.port, 1, T.TABLE_SIZE - 1, 2)
    assert result == COMM_SUCCESS
    assert error == T.ERR_RANGE
    # No parameters: the SDK's slice [5:7] of a 6-byte status packet holds only the checksum.
    assert len(data) <= 1
    data, result, error = one.ph.readTxRx(one.port, 1, 0, T.TABLE_SIZE + 1)
    assert (result, error) == (COMM_SUCCESS, T.ERR_RANGE)


def test_read_of_length_zero_is_a_range_error(one):
    data, result, error = one.ph.readTxRx(one.port, 1, 0, 0)
    assert (result, error) == (COMM_SUCCESS, T.ERR_RANGE)


# ---------------------------------------------------------------------------------------------
# Writing every writable register
# ---------------------------------------------------------------------------------------------

def _writable_values(bus):
    """A valid value, different from the factory default, for every writable address, chosen
    so that no alarm condition starts (limits keep bracketing the present readings)."""
    volts = bus.read(1, T.PRESENT_VOLTAGE)
    temp = bus.read(1, T.PRESENT_TEMPERATURE)
    assert 50 < volts < 250, f"Present Voltage {volts}"
    return {
        T.RETURN_DELAY_TIME: 10,
        T.CW_ANGLE_LIMIT: 100,
        T.CCW_ANGLE_LIMIT: 900,
        T.HIGHEST_LIMIT_TEMP: max(temp + 10, 100),
        T.LOWEST_LIMIT_VOLTAGE: max(50, volts - 5),
        T.HIGHEST_LIMIT_VOLTAGE: min(250, volts + 5),
        T.MAX_TORQUE: 800,
        T.ALARM_LED: 0x25,
        T.ALARM_SHUTDOWN: 0x25,
        T.RESERVED_19: 1,
        T.TORQUE_ENABLE: 1,
        T.LED: 1,
        T.CW_COMPLIANCE_MARGIN: 5,
        T.CCW_COMPLIANCE_MARGIN: 6,
        T.CW_COMPLIANCE_SLOPE: 20,  # stored as written; it acts as 32
        T.CCW_COMPLIANCE_SLOPE: 100,  # acts as 128
        T.GOAL_POSITION: 600,
        T.MOVING_SPEED: 300,
        T.TORQUE_LIMIT: 700,
        T.REGISTERED_INSTRUCTION: 0,
        T.PUNCH: 100,
    }


SPECIAL = {T.ID, T.BAUD_RATE, T.STATUS_RETURN_LEVEL, T.LOCK}  # tested on their own below


def test_every_writable_register_takes_a_valid_value_and_reads_it_back(one):
    # Park the goal in the middle first, so new angle limits never put it outside.
    one.write(1, T.GOAL_POSITION, 512)
    values = _writable_values(one)
    writable = [it for it in P.TABLE if it.access == P.RW and it.addr not in SPECIAL]
    assert sorted(values) == sorted(it.addr for it in writable)
    originals = {}
    for it in writable:
        originals[it.addr] = one.read(1, it.addr)
        one.write(1, it.addr, values[it.addr])
        got = one.read(1, it.addr)
        assert got == values[it.addr], f"{it.name} (addr {it.addr}): wrote {values[it.addr]}, read {got}"
    one.write(1, T.TORQUE_ENABLE, 0)
    # EEPROM items go back to what they were.
    for it in writable:
        if it.addr < T.EEPROM_SIZE:
            one.write(1, it.addr, originals[it.addr])
            assert one.read(1, it.addr) == originals[it.addr], it.name


def test_eeprom_writes_survive_a_power_cycle_and_ram_does_not(emulators, bus_factory):
    emu = emulators(ids="1")
    bus = bus_factory(emu.path)
    bus.write(1, T.RETURN_DELAY_TIME, 10)
    bus.write(1, T.CCW_ANGLE_LIMIT, 900)
    bus.write(1, T.LED, 1)
    bus.write(1, T.PUNCH, 100)
    bus.close()
    emu.restart()
    bus = bus_factory(emu.path)
    assert bus.read(1, T.RETURN_DELAY_TIME) == 10
    assert bus.read(1, T.CCW_ANGLE_LIMIT) == 900
    assert bus.read(1, T.LED) == 0
    assert bus.read(1, T.PUNCH) == 32


def test_one_byte_of_a_16_bit_item_may_be_written_alone(one):
    one.write(1, T.GOAL_POSITION, 0x0123)
    one.write(1, T.GOAL_POSITION, 0x45, size=1)        # low byte only
    assert one.read(1, T.GOAL_POSITION) == 0x0145
    one.write(1, T.GOAL_POSITION + 1, 0x02, size=1)    # high byte only
    assert one.read(1, T.GOAL_POSITION) == 0x0245
    # The range check applies to the resulting 16-bit value: 0x0445 > 1023.
    one.write(1, T.GOAL_POSITION + 1, 0x04, size=1, want_error=T.ERR_RANGE)
    assert one.read(1, T.GOAL_POSITION) == 0x0245


# ---------------------------------------------------------------------------------------------
# Range Error (0x08): nothing is written
# ---------------------------------------------------------------------------------------------

OUT_OF_RANGE = [
    (T.ID, 254), (T.BAUD_RATE, 255), (T.RETURN_DELAY_TIME, 255), (T.CW_ANGLE_LIMIT, 1024),
    (T.CCW_ANGLE_LIMIT, 1024), (T.HIGHEST_LIMIT_TEMP, 151), (T.LOWEST_LIMIT_VOLTAGE, 49),
    (T.LOWEST_LIMIT_VOLTAGE, 251), (T.HIGHEST_LIMIT_VOLTAGE, 49), (T.HIGHEST_LIMIT_VOLTAGE, 251),
    (T.MAX_TORQUE, 1024), (T.STATUS_RETURN_LEVEL, 3), (T.ALARM_LED, 128), (T.ALARM_SHUTDOWN, 128),
    (T.RESERVED_19, 2), (T.TORQUE_ENABLE, 2), (T.LED, 2), (T.CW_COMPLIANCE_MARGIN, 255),
    (T.CCW_COMPLIANCE_MARGIN, 255), (T.CW_COMPLIANCE_SLOPE, 0), (T.CCW_COMPLIANCE_SLOPE, 255),
    (T.GOAL_POSITION, 1024), (T.MOVING_SPEED, 1024), (T.TORQUE_LIMIT, 1024), (T.REGISTERED_INSTRUCTION, 2),
    (T.LOCK, 0), (T.PUNCH, 1024),
    # read-only and reserved addresses, even with the value they already hold
    (T.MODEL_NUMBER, 12), (T.FIRMWARE_VERSION, 1), (T.RESERVED_10, 0), (T.DOWN_CALIBRATION, 0),
    (T.UP_CALIBRATION, 0), (T.PRESENT_POSITION, 0), (T.PRESENT_SPEED, 0), (T.PRESENT_LOAD, 0),
    (T.PRESENT_VOLTAGE, 0), (T.PRESENT_TEMPERATURE, 0), (T.RESERVED_45, 0), (T.MOVING, 1),
]


@pytest.mark.parametrize("addr,value", OUT_OF_RANGE,
                         ids=[f"{P.BY_ADDR[a].name}={v}" for a, v in OUT_OF_RANGE])
def test_out_of_range_write_is_a_range_error_and_changes_nothing(module_bus, addr, value):
    bus = module_bus
    before = bus.read(1, addr)
    bus.write(1, addr, value, want_error=T.ERR_RANGE)
    if addr not in range(T.PRESENT_POSITION, T.PRESENT_TEMPERATURE + 1):   # Present*: they change
        assert bus.read(1, addr) == before
    assert bus.ping(1) == 12        # the error is an event: the next status packet is clean


@pytest.fixture(scope="module")
def module_bus(module_emulators):
    """One servo shared by the Range Error cases: a rejected write changes nothing."""
    emu = module_emulators(ids="1")
    bus = Bus(emu.path)
    yield bus
    bus.close()


def test_write_window_past_address_49_is_a_range_error(one):
    result, error = one.ph.writeTxRx(one.port, 1, T.TABLE_SIZE - 1, 2, [1, 0])
    assert (result, error) == (COMM_SUCCESS, T.ERR_RANGE)


def test_write_is_atomic_one_bad_item_rejects_the_whole_packet(one):
    goal = one.read(1, T.GOAL_POSITION)
    new_goal = 700 if goal != 700 else 300
    # Goal Position (valid) + Moving Speed 1024 (invalid in joint mode), one packet.
    data = [DXL_LOBYTE(new_goal), DXL_HIBYTE(new_goal), DXL_LOBYTE(1024), DXL_HIBYTE(1024)]
    result, error = one.ph.writeTxRx(one.port, 1, T.GOAL_POSITION, 4, data)
    assert (result, error) == (COMM_SUCCESS, T.ERR_RANGE)
    assert one.read(1, T.GOAL_POSITION) == goal
    assert one.read(1, T.MOVING_SPEED) == 0


# ---------------------------------------------------------------------------------------------
# Angle Limit (0x02): the goal is stored, the bit is a condition
# ---------------------------------------------------------------------------------------------

def test_goal_outside_the_angle_limits_is_stored_with_the_angle_limit_bit(one):
    one.write(1, T.GOAL_POSITION, 512)
    one.write(1, T.CW_ANGLE_LIMIT, 200)
    one.write(1, T.CCW_ANGLE_LIMIT, 800)
    one.write(1, T.GOAL_POSITION, 100, want_error=T.ERR_ANGLE_LIMIT)
    # Stored, and the condition holds in every status packet while the goal lies outside.
    assert one.read(1, T.GOAL_POSITION, want_error=T.ERR_ANGLE_LIMIT) == 100
    _, result, error = one.raw(1, T.INST_PING)
    assert (result, error) == (COMM_SUCCESS, T.ERR_ANGLE_LIMIT)
    one.write(1, T.GOAL_POSITION, 900, want_error=T.ERR_ANGLE_LIMIT)
    one.write(1, T.GOAL_POSITION, 500)             # inside again: the bit clears
    assert one.read(1, T.GOAL_POSITION) == 500
    # Moving a limit so that the stored goal falls outside raises the condition too.
    one.write(1, T.CW_ANGLE_LIMIT, 600, want_error=T.ERR_ANGLE_LIMIT)
    one.write(1, T.CW_ANGLE_LIMIT, 0)
    assert one.read(1, T.CW_ANGLE_LIMIT) == 0


def test_any_goal_in_wheel_mode_sets_the_angle_limit_bit(one):
    one.write(1, T.CCW_ANGLE_LIMIT, 0)             # CW = CCW = 0: wheel mode
    one.write(1, T.GOAL_POSITION, 512, want_error=T.ERR_ANGLE_LIMIT)
    assert one.read(1, T.GOAL_POSITION, want_error=T.ERR_ANGLE_LIMIT) == 512
    # Moving Speed accepts 0..2047 in wheel mode.
    one.write(1, T.MOVING_SPEED, 1024 + 300, want_error=T.ERR_ANGLE_LIMIT)
    assert one.read(1, T.MOVING_SPEED, want_error=T.ERR_ANGLE_LIMIT) == 1324
    one.write(1, T.MOVING_SPEED, 0, want_error=T.ERR_ANGLE_LIMIT)
    one.write(1, T.CCW_ANGLE_LIMIT, 1023)          # back to joint mode: goal 512 is inside
    assert one.read(1, T.GOAL_POSITION) == 512


# ---------------------------------------------------------------------------------------------
# Status Return Level
# ---------------------------------------------------------------------------------------------

def test_status_return_level_1_answers_read_only_and_0_answers_ping_only(one):
    one.write(1, T.STATUS_RETURN_LEVEL, 1)         # answered: the old level (2) applies
    assert one.read(1, T.STATUS_RETURN_LEVEL) == 1
    result, _ = one.ph.write1ByteTxRx(one.port, 1, T.LED, 1)
    assert result == COMM_RX_TIMEOUT               # WRITE: no reply at level 1 ...
    assert one.read(1, T.LED) == 1                 # ... but applied
    one.write_no_reply(1, T.STATUS_RETURN_LEVEL, 0)
    _, result, _ = one.ph.read1ByteTxRx(one.port, 1, T.STATUS_RETURN_LEVEL)
    assert result == COMM_RX_TIMEOUT               # READ: no reply at level 0
    _, result, error = one.raw(1, T.INST_PING)     # PING still answered
    assert (result, error) == (COMM_SUCCESS, 0)
    one.write_no_reply(1, T.STATUS_RETURN_LEVEL, 2)
    assert one.read(1, T.STATUS_RETURN_LEVEL) == 2
    one.write(1, T.LED, 0)


# ---------------------------------------------------------------------------------------------
# Instructions: REG_WRITE / ACTION, RESET, unknown
# ---------------------------------------------------------------------------------------------

def test_reg_write_then_action_applies_the_registered_write(one):
    goal = one.read(1, T.GOAL_POSITION)
    new_goal = 300 if goal != 300 else 700
    result, error = one.ph.regWriteTxRx(one.port, 1, T.GOAL_POSITION, 2,
                                        [DXL_LOBYTE(new_goal), DXL_HIBYTE(new_goal)])
    assert (result, error) == (COMM_SUCCESS, 0)
    assert one.read(1, T.REGISTERED_INSTRUCTION) == 1
    assert one.read(1, T.GOAL_POSITION) == goal    # not yet
    assert one.ph.action(one.port, 1) == COMM_SUCCESS
    assert one.read(1, T.GOAL_POSITION) == new_goal
    assert one.read(1, T.REGISTERED_INSTRUCTION) == 0


def test_action_with_nothing_registered_is_an_instruction_error(one):
    # The SDK's action() returns no error byte; txRxPacket sends the same ACTION packet.
    _, result, error = one.raw(1, T.INST_ACTION)
    assert (result, error) == (COMM_SUCCESS, T.ERR_INSTRUCTION)


def test_reg_write_is_validated_at_once_and_a_new_one_replaces_the_old(one):
    result, error = one.ph.regWriteTxRx(one.port, 1, T.GOAL_POSITION, 2, [0x00, 0x04])  # 1024
    assert (result, error) == (COMM_SUCCESS, T.ERR_RANGE)
    assert one.read(1, T.REGISTERED_INSTRUCTION) == 0
    one.ph.regWriteTxRx(one.port, 1, T.LED, 1, [1])
    result, error = one.ph.regWriteTxRx(one.port, 1, T.PUNCH, 2, [64, 0])
    assert (result, error) == (COMM_SUCCESS, 0)
    assert one.ph.action(one.port, 1) == COMM_SUCCESS
    assert one.read(1, T.PUNCH) == 64
    assert one.read(1, T.LED) == 0                 # replaced, never applied


def test_writing_0_to_registered_instruction_discards_the_registered_write(one):
    one.ph.regWriteTxRx(one.port, 1, T.LED, 1, [1])
    assert one.read(1, T.REGISTERED_INSTRUCTION) == 1
    one.write(1, T.REGISTERED_INSTRUCTION, 0)
    assert one.read(1, T.REGISTERED_INSTRUCTION) == 0
    _, result, error = one.raw(1, T.INST_ACTION)
    assert (result, error) == (COMM_SUCCESS, T.ERR_INSTRUCTION)
    assert one.read(1, T.LED) == 0


def test_broadcast_action_applies_every_servos_registered_write(emulators, bus_factory):
    ids = P.parse_ids("1-6")
    bus = bus_factory(emulators(ids="1-6").path)
    for i in ids:
        result, error = bus.ph.regWriteTxRx(bus.port, i, T.GOAL_POSITION, 2, [DXL_LOBYTE(100 + 50 * i),
                                                                     DXL_HIBYTE(100 + 50 * i)])
        assert (result, error) == (COMM_SUCCESS, 0), f"id {i}"
    assert bus.ph.action(bus.port, BROADCAST_ID) == COMM_SUCCESS
    settle(bus.port)
    for i in ids:
        assert bus.read(i, T.GOAL_POSITION) == 100 + 50 * i, f"id {i}"
        assert bus.read(i, T.REGISTERED_INSTRUCTION) == 0, f"id {i}"


def test_unknown_instruction_is_an_instruction_error(one):
    assert 0x07 not in T.INSTRUCTIONS
    _, result, error = one.raw(1, 0x07)
    assert (result, error) == (COMM_SUCCESS, T.ERR_INSTRUCTION)


def test_bulk_read_is_not_an_ax12_instruction(emulators, bus_factory):
    """BULK_READ (0x92) goes to the broadcast ID: an AX-12 does not answer it.
    (The SDK's GroupBulkRead cannot send it for Protocol 1.0 in 4.1.0: it calls
    bulkReadTx with four arguments; the packet handler's bulkReadTx is used directly.)"""
    bus = bus_factory(emulators(ids="1-2").path)
    assert bus.ph.bulkReadTx(bus.port, [2, 1, T.GOAL_POSITION, 2, 2, T.GOAL_POSITION], 6) == COMM_SUCCESS
    _, result, _ = bus.ph.readRx(bus.port, 1, 2)
    assert result == COMM_RX_TIMEOUT
    assert bus.ping(1) == 12 and bus.ping(2) == 12


def test_factory_reset_restores_defaults_and_id_1(emulators, bus_factory):
    emu = emulators(ids="7")
    bus = bus_factory(emu.path)
    bus.write(7, T.RETURN_DELAY_TIME, 10)
    bus.write(7, T.CCW_ANGLE_LIMIT, 900)
    bus.write(7, T.LED, 1)
    result, error = bus.ph.factoryReset(bus.port, 7)   # the reply comes from ID 7
    assert (result, error) == (COMM_SUCCESS, 0), bus.ph.getTxRxResult(result)
    settle(bus.port)
    assert bus.ping(1) == 12
    assert not bus.answers(7)
    for item in P.TABLE:
        want = P.default(item, "ax12")
        if item.addr < T.EEPROM_SIZE and want is not P.RUNTIME:
            assert bus.read(1, item.addr) == want, item.name
    # Persisted: still ID 1 after a power cycle.
    bus.close()
    emu.restart()
    bus = bus_factory(emu.path)
    assert bus.ping(1) == 12
    assert bus.read(1, T.RETURN_DELAY_TIME) == 250


def test_factory_reset_after_every_eeprom_item_changed_is_answered_in_time(emulators,
                                                                         bus_factory):
    """docs/policy.md "Replies": the reply starts Return Delay Time after the instruction's
    last byte, so the SDK's factoryReset() (34 ms timeout) gets its status packet however much
    EEPROM the reset has to rewrite."""
    bus = bus_factory(emulators(ids="1").path)
    bus.write(1, T.GOAL_POSITION, 512)
    values = _writable_values(bus)
    for addr in (T.RETURN_DELAY_TIME, T.CW_ANGLE_LIMIT, T.CCW_ANGLE_LIMIT, T.HIGHEST_LIMIT_TEMP,
                 T.LOWEST_LIMIT_VOLTAGE, T.HIGHEST_LIMIT_VOLTAGE, T.MAX_TORQUE, T.ALARM_LED, T.ALARM_SHUTDOWN,
                 T.RESERVED_19):
        bus.write(1, addr, values[addr])
    t0 = time.perf_counter()
    result, error = bus.ph.factoryReset(bus.port, 1)
    elapsed_ms = (time.perf_counter() - t0) * 1e3
    assert (result, error) == (COMM_SUCCESS, 0), (
        f"factoryReset: {bus.ph.getTxRxResult(result)} after {elapsed_ms:.1f} ms")
    settle(bus.port, 0.2)
    assert bus.read(1, T.RETURN_DELAY_TIME) == 250
    assert bus.read(1, T.CCW_ANGLE_LIMIT) == 1023


def test_an_eeprom_write_is_answered_at_once_and_the_bus_goes_on_while_it_is_stored(emulators,
                                                                                      bus_factory):
    """docs/policy.md "Settings": an 8-byte WRITE of the EEPROM area (addresses 11..18) is
    answered at its Return Delay Time, not after the 8 x 3.4 ms its bytes take to store; the
    new values read back at once; READs of other servos and a broadcast SYNC_WRITE sent while
    it is being stored are answered and applied; the values survive a restart."""
    emu = emulators(ids="1-3")
    bus = bus_factory(emu.path)
    settings = [80, 55, 150, 0x00, 0x02, 1, 0x25, 0x25]   # addresses 11..18, all changed
    t0 = time.perf_counter()
    result, error = bus.ph.writeTxRx(bus.port, 1, T.HIGHEST_LIMIT_TEMP, len(settings), settings)
    elapsed_ms = (time.perf_counter() - t0) * 1e3
    assert (result, error) == (COMM_SUCCESS, 0), bus.ph.getTxRxResult(result)
    # Storing first would take (8 changed bytes + 3) x 3.4 ms = 37 ms; the request and reply
    # take 0.2 ms on the wire and 0.5 ms of Return Delay Time (250).
    assert elapsed_ms < 15, f"answered after {elapsed_ms:.1f} ms"
    data, result, error = bus.ph.readTxRx(bus.port, 1, T.HIGHEST_LIMIT_TEMP, len(settings))
    assert (result, error) == (COMM_SUCCESS, 0)
    assert list(data) == settings
    # Meanwhile (the store is still under way): other servos answer, a SYNC_WRITE applies.
    for i in (2, 3):
        assert bus.read(i, T.ID) == i
    sw = GroupSyncWrite(bus.port, bus.ph, T.LED, 1)
    for i in (1, 2, 3):
        assert sw.addParam(i, [1])
    assert sw.txPacket() == COMM_SUCCESS
    settle(bus.port)
    for i in (1, 2, 3):
        assert bus.read(i, T.LED) == 1, f"id {i}"
    assert bus.read(1, T.STATUS_RETURN_LEVEL) == 1
    # Stored: they survive a restart.
    bus.close()
    emu.restart()
    bus = bus_factory(emu.path)
    data, result, error = bus.ph.readTxRx(bus.port, 1, T.HIGHEST_LIMIT_TEMP, len(settings))
    assert (result, error) == (COMM_SUCCESS, 0)
    assert list(data) == settings


# ---------------------------------------------------------------------------------------------
# Motion as a robot waits for it: Moving, Overload
# ---------------------------------------------------------------------------------------------

def _wait_until_still(bus, dxl_id, timeout_s=3.0):
    deadline = time.monotonic() + timeout_s
    while bus.read(dxl_id, T.MOVING) != 0:
        assert time.monotonic() < deadline, "still Moving"
        time.sleep(0.02)


def test_moving_reads_1_right_after_every_goal_write_600_counts_away(emulators, bus_factory):
    """docs/policy.md "Motion semantics": the most common way to wait for a move, a goal
    write followed by polling Moving until 0, never sees 0 on its first poll."""
    bus = bus_factory(emulators(ids="1").path)
    bus.write(1, T.TORQUE_ENABLE, 1)
    _wait_until_still(bus, 1)
    for move in range(10):
        goal = 200 if bus.read(1, T.PRESENT_POSITION) > 500 else 800
        bus.write(1, T.GOAL_POSITION, goal)
        assert bus.read(1, T.MOVING) == 1, f"move {move}: Moving read 0 right after the goal write"
        _wait_until_still(bus, 1)
        assert abs(bus.read(1, T.PRESENT_POSITION) - goal) <= 3, f"move {move}"


def test_a_load_of_twice_the_stall_torque_against_the_goal_trips_overload_and_shutdown(emulators,
                                                                                      bus_factory):
    """docs/policy.md "Alarms": a load of 3 N m (about twice the stall torque at 9.6 V) drags
    the output backwards at full drive; after the 1000 ms window the Overload bit is set and
    Alarm Shutdown (overload bit set) turns the torque off."""
    bus = bus_factory(emulators(ids="1", extra=("--load-torque", "-3.0")).path)
    bus.write(1, T.ALARM_SHUTDOWN, T.ERR_OVERLOAD | T.ERR_OVERHEATING)
    bus.write(1, T.TORQUE_ENABLE, 1)
    start = bus.read(1, T.PRESENT_POSITION)
    bus.write(1, T.GOAL_POSITION, start + 300)
    t0 = time.monotonic()
    dragged = False
    while True:
        torque, result, error = bus.ph.read1ByteTxRx(bus.port, 1, T.TORQUE_ENABLE)
        elapsed = time.monotonic() - t0
        if result == COMM_SUCCESS and torque == 0:
            break
        assert elapsed < 4.0, "no overload shutdown within 4 s"
        if result == COMM_SUCCESS and elapsed < 0.8:
            assert not error & T.ERR_OVERLOAD, f"overload after {elapsed:.2f} s, before the window"
            speed, result, _ = bus.ph.read2ByteTxRx(bus.port, 1, T.PRESENT_SPEED)
            dragged = dragged or (result == COMM_SUCCESS and speed & 0x400 and speed & 0x3FF > 20)
        time.sleep(0.05)
    assert error & T.ERR_OVERLOAD, f"torque off without the Overload bit (error 0x{error:02x})"
    assert elapsed >= 0.95, f"shut down after {elapsed:.2f} s, inside the 1000 ms window"
    assert dragged, "the output was never seen dragged backwards (CW) past 20 units"


# ---------------------------------------------------------------------------------------------
# ID and baud changes
# ---------------------------------------------------------------------------------------------

def test_id_change_replies_with_the_old_id_then_answers_at_the_new_one(emulators, bus_factory):
    bus = bus_factory(emulators(ids="3").path)
    bus.write(3, T.ID, 9)          # the SDK only accepts a status packet from ID 3
    settle(bus.port)
    assert bus.ping(9) == 12
    assert bus.read(9, T.ID) == 9
    assert not bus.answers(3)


@pytest.mark.parametrize("value,host_baud", [(34, 57600), (3, 500000), (207, 9600)],
                         ids=["57142bps", "500kbps", "9615bps"])
def test_baud_change_then_reconnect_at_the_new_rate(emulators, bus_factory, value, host_baud):
    assert abs(P.baud_of(value) - host_baud) / host_baud < 0.03
    path = emulators(ids="1").path
    bus = bus_factory(path)
    bus.write(1, T.BAUD_RATE, value)  # answered at the old rate (1 Mbps)
    settle(bus.port)
    assert bus.port.setBaudRate(host_baud)
    assert bus.ping(1) == 12
    assert bus.read(1, T.BAUD_RATE) == value
    # At the old rate nothing gets through any more.
    assert bus.port.setBaudRate(BAUD_1M)
    assert not bus.answers(1)
    # Back to 1 Mbps, set from the new rate.
    assert bus.port.setBaudRate(host_baud)
    bus.write(1, T.BAUD_RATE, 1)
    settle(bus.port)
    assert bus.port.setBaudRate(BAUD_1M)
    assert bus.ping(1) == 12


# ---------------------------------------------------------------------------------------------
# Several servos on one bus: SYNC_WRITE
# ---------------------------------------------------------------------------------------------

def test_ping_finds_every_servo_on_a_multi_servo_bus(emulators, bus_factory):
    bus = bus_factory(emulators(ids="1-6").path)
    for i in P.parse_ids("1-6"):
        assert bus.ping(i) == 12
        assert bus.read(i, T.ID) == i
    assert not bus.answers(7)


def test_group_sync_write_reaches_every_servo(emulators, bus_factory):
    ids = P.parse_ids("1-6")
    bus = bus_factory(emulators(ids="1-6").path)
    sw = GroupSyncWrite(bus.port, bus.ph, T.GOAL_POSITION, 2)
    for i in ids:
        goal = 200 + 100 * i
        assert sw.addParam(i, [DXL_LOBYTE(goal), DXL_HIBYTE(goal)])
    assert sw.txPacket() == COMM_SUCCESS
    settle(bus.port)               # broadcast: no status packets
    for i in ids:
        assert bus.read(i, T.GOAL_POSITION) == 200 + 100 * i, f"id {i}"

    # Goal Position and Moving Speed together (4 bytes per servo).
    sw4 = GroupSyncWrite(bus.port, bus.ph, T.GOAL_POSITION, 4)
    for i in ids:
        sw4.addParam(i, [DXL_LOBYTE(1000 - 10 * i), DXL_HIBYTE(1000 - 10 * i),
                         DXL_LOBYTE(50 * i), DXL_HIBYTE(50 * i)])
    assert sw4.txPacket() == COMM_SUCCESS
    settle(bus.port)
    for i in ids:
        assert bus.read(i, T.GOAL_POSITION) == 1000 - 10 * i, f"id {i}"
        assert bus.read(i, T.MOVING_SPEED) == 50 * i, f"id {i}"


def test_sync_write_slice_out_of_range_is_dropped_for_that_servo_only(emulators, bus_factory):
    bus = bus_factory(emulators(ids="1-2").path)
    goal1 = bus.read(1, T.GOAL_POSITION)
    sw = GroupSyncWrite(bus.port, bus.ph, T.GOAL_POSITION, 2)
    sw.addParam(1, [0x00, 0x04])           # 1024: out of range for servo 1
    sw.addParam(2, [0x20, 0x01])           # 288: fine for servo 2
    assert sw.txPacket() == COMM_SUCCESS
    settle(bus.port)
    assert bus.read(1, T.GOAL_POSITION) == goal1
    assert bus.read(2, T.GOAL_POSITION) == 288


# ---------------------------------------------------------------------------------------------
# Lock (profile ax12)
# ---------------------------------------------------------------------------------------------

def test_lock_allows_only_addresses_24_to_35_until_a_power_cycle(emulators, bus_factory):
    emu = emulators(ids="1")
    bus = bus_factory(emu.path)
    bus.write(1, T.LOCK, 1)
    assert bus.read(1, T.LOCK) == 1
    bus.write(1, T.LED, 1)
    bus.write(1, T.GOAL_POSITION, 400)
    bus.write(1, T.TORQUE_LIMIT, 500)
    bus.write(1, T.RETURN_DELAY_TIME, 10, want_error=T.ERR_RANGE)
    bus.write(1, T.PUNCH, 64, want_error=T.ERR_RANGE)
    bus.write(1, T.LOCK, 1, want_error=T.ERR_RANGE)
    assert bus.read(1, T.RETURN_DELAY_TIME) == 250
    result, error = bus.ph.factoryReset(bus.port, 1)
    assert (result, error) == (COMM_SUCCESS, T.ERR_INSTRUCTION)
    bus.close()
    emu.restart()
    bus = bus_factory(emu.path)
    assert bus.read(1, T.LOCK) == 0
    bus.write(1, T.RETURN_DELAY_TIME, 10)
