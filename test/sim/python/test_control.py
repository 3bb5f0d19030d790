# SPDX-License-Identifier: GPL-3.0-or-later
"""The control socket of `ax12-emu serve` (docs/dashboard.md) and `scripts/ax12 world`, through
the real path: the emulator running the firmware ELF, its socket, the command line, and
DynamixelSDK on the pty at the same time."""
import subprocess
import threading
import time

import dynamixel_sdk as sdk
import pytest

import ax12_control
import ax12_packets as P
import ax12_table as T
from conftest import servo, wait_for, world


def open_port(device):
    port = sdk.PortHandler(device)
    assert port.openPort()
    assert port.setBaudRate(1000000)
    return port, sdk.PacketHandler(1.0)


def test_status_reads_the_firmware_table_and_the_plant(emulator, tmp_path):
    emulator("--realtime", "--ids", "1,4", "--state-dir", str(tmp_path))
    with ax12_control.Control(ax12_control.default_socket_path(str(tmp_path))) as control:
        status = control.request("status", table=True)
    assert status["profile"] == "ax12" and status["mcu"] == "atmega88"
    assert [s["slot"] for s in status["servos"]] == [1, 4]
    s4 = servo(status, 4)
    assert s4["id"] == 4 and s4["table"][T.ID] == 4 and s4["table"][T.MODEL_NUMBER] == 12
    assert s4["torque_enable"] == 0 and s4["conditions"] == 0
    assert 9.0 < s4["supply_v"] < 9.7 and abs(s4["angle_deg"] - 150.0) < 1.0
    assert s4["world"] == {"supply": 9.6, "ambient": 25, "load": "none"}


def test_world_options_per_servo_at_start_and_at_run_time(emulator, tmp_path):
    emulator("--realtime", "--ids", "1-3", "--state-dir", str(tmp_path), "--supply", "11",
             "--world", "2:load-spring=2,100", "--world", "3:ambient=40")
    sock = ax12_control.default_socket_path(str(tmp_path))
    with ax12_control.Control(sock) as control:
        worlds = {s["slot"]: s["world"] for s in control.request("status")["servos"]}
    assert worlds[1] == {"supply": 11, "ambient": 25, "load": "none"}
    assert worlds[2]["load"] == "spring" and worlds[2]["spring_nm_rad"] == 2 and worlds[2]["supply"] == 11
    assert abs(worlds[2]["rest_deg"] - 100) < 1e-9
    assert worlds[3]["ambient"] == 40 and worlds[3]["load"] == "none"

    done = world("--state-dir", str(tmp_path), "--servo", "3", "--load-torque", "0.4", "--supply", "7.5")
    assert done.returncode == 0, done.stderr
    assert "servo 3: supply 7.5 V, ambient 40 degC, constant torque 0.4 N m" in done.stdout
    with ax12_control.Control(sock) as control:
        status = control.request("status")
    assert servo(status, 3)["world"]["load_torque_nm"] == 0.4
    assert servo(status, 1)["world"]["supply"] == 11  # the others unchanged
    # The supply reaches the firmware: Present Voltage follows the new 7.5 V.
    with ax12_control.Control(sock) as control:
        wait_for(lambda: servo(control.request("status"), 3)["present_voltage"] in (73, 74, 75), 5,
                 "Present Voltage near 75 (7.5 V) on servo 3")


def test_a_servo_with_torque_off_dragged_by_a_load_is_braked_by_its_bridge(emulator, tmp_path):
    """docs/dashboard.md's `scripts/ax12 world --servo 2 --load-torque -3` on servos whose torque
    is off: the motor's back-EMF, clamped by the H-bridge's body diodes at the supply plus two
    diode drops, brakes the output (docs/plant.md "Electrical model"). Servo 2 turns CW at a
    steady speed above the 62 rpm where the diodes start to conduct and below 150 rpm (the
    model: 117 rpm), returning current to the supply, where open terminals would let it spin
    at 7000 rpm (tens of thousands of degrees a second on the dashboard). The others stay put."""
    emulator("--realtime", "--ids", "1-3", "--state-dir", str(tmp_path))
    done = world("--state-dir", str(tmp_path), "--servo", "2", "--load-torque", "-3")
    assert done.returncode == 0, done.stderr
    with ax12_control.Control(ax12_control.default_socket_path(str(tmp_path))) as control:
        time.sleep(0.5)  # up to speed: the mechanical time constant is about 20 ms
        first = control.request("status")
        time.sleep(1.0)
        last = control.request("status")
    seconds = (last["time_us"] - first["time_us"]) / 1e6
    assert seconds > 0.2, seconds
    s2 = servo(last, 2)
    assert s2["torque_enable"] == 0 and s2["duty"] == 0
    deg_per_s = (s2["angle_deg"] - servo(first, 2)["angle_deg"]) / seconds
    assert -150 * 6 < deg_per_s < -62 * 6, deg_per_s  # rpm x 6 = deg/s
    assert -150 < s2["speed_rpm"] < -62, s2["speed_rpm"]
    assert s2["motor_current_a"] > 0.3, s2  # opposing the motion: braking
    assert s2["supply_v"] > 9.6, s2  # the current goes back into the supply
    for slot in (1, 3):
        assert abs(servo(last, slot)["angle_deg"] - 150.0) < 1.0
        assert servo(last, slot)["speed_rpm"] == 0


def test_world_refuses_bad_input_and_changes_nothing(emulator, tmp_path):
    emulator("--realtime", "--ids", "1,2", "--state-dir", str(tmp_path))
    sock = ax12_control.default_socket_path(str(tmp_path))
    for args, message in [(["--servo", "9", "--supply", "8"], "no servo 9"),
                          (["--servo", "1", "--supply", "99"], "bad --supply '99'"),
                          (["--servo", "all", "--ambient", "-100"], "bad --ambient"),
                          (["--servo", "2", "--load-spring", "2,1,3"], "bad --load-spring")]:
        done = world("--state-dir", str(tmp_path), *args)
        assert done.returncode == 1, (args, done.stdout, done.stderr)
        assert message in done.stderr
    with ax12_control.Control(sock) as control:
        for s in control.request("status")["servos"]:
            assert s["world"] == {"supply": 9.6, "ambient": 25, "load": "none"}
        for bad, message in [({"op": "world", "id": 1, "set": {"angle": 30}}, "only set at start"),
                             ({"op": "world", "id": 1, "set": {"load-torque": 1, "load-arm": [1, 0.1]}},
                              "one load at a time"),
                             ({"op": "world", "id": "x"}, "\"id\""),
                             ({"op": "send", "bytes": "FF FF 01"}, "not a Protocol 1.0 packet"),
                             ({"op": "send", "bytes": "FF FF 01 09 01 FB"}, "LENGTH"),
                             ({"op": "subscribe", "telemetry_hz": 1000}, "telemetry_hz"),
                             ({"op": "nope"}, "unknown op")]:
            with pytest.raises(ax12_control.ControlError, match=message):
                control.request(bad.pop("op"), **bad)
        control.sock.sendall(b"{not json\n")
        assert "JSON object" in control.read_line()["error"]
        control.sock.sendall(b"x" * 9000 + b"\n")
        assert "too long" in control.read_line()["error"]
        assert control.request("status")["servos"][0]["world"]["supply"] == 9.6  # still answering
    done = world("--control", str(tmp_path / "nobody.sock"))
    assert done.returncode == 3 and "cannot reach" in done.stderr


def test_a_packet_sent_through_the_socket_is_answered_and_the_client_never_sees_it(emulator, tmp_path):
    """The dashboard's edits: a packet on the bus from a second master. The servo answers it, the
    client on the pty never sees either packet, and DynamixelSDK polling the same servo at the
    same time goes on (its exchanges wait for the bus; a few may time out on a loaded machine,
    where the kernel sometimes holds a pty write back for a while, with or without a second
    master: that is not counted against the emulator)."""
    import serial
    emu = emulator("--realtime", "--ids", "1,2", "--state-dir", str(tmp_path))
    sock = ax12_control.default_socket_path(str(tmp_path))
    with serial.Serial(emu.device, 1000000, timeout=0.3) as quiet, ax12_control.Control(sock) as control:
        quiet.reset_input_buffer()
        for value in (40, 41, 42):
            packet = P.instruction_packet(1, T.INST_WRITE, [T.CW_COMPLIANCE_SLOPE, value])
            reply = control.request("send", bytes=packet.hex(" "))
            assert P.parse(bytes.fromhex(reply["reply"])) == P.parse(P.status_packet(1, 0))
        reply = control.request("send", bytes=P.instruction_packet(2, T.INST_READ, [T.ID, 1]).hex())
        assert P.parse(bytes.fromhex(reply["reply"])).params == [2]
        bad = bytearray(P.instruction_packet(1, T.INST_PING))
        bad[-1] ^= 0x55
        reply = control.request("send", bytes=list(bad))
        assert P.parse(bytes.fromhex(reply["reply"])).code == T.ERR_CHECKSUM
        reply = control.request("send", bytes=P.instruction_packet(7, T.INST_PING).hex())
        assert reply["reply"] == ""  # nobody has ID 7
        assert quiet.read(64) == b""  # none of those bytes reached the client

    port, handler = open_port(emu.device)
    outcomes = []
    stop = threading.Event()

    def poll():
        while not stop.is_set():
            _, result, error = handler.read2ByteTxRx(port, 1, T.PRESENT_POSITION)
            outcomes.append((result, error))

    poller = threading.Thread(target=poll)
    poller.start()
    try:
        with ax12_control.Control(sock) as control:
            for value in range(43, 63):
                packet = P.instruction_packet(1, T.INST_WRITE, [T.CW_COMPLIANCE_SLOPE, value])
                reply = control.request("send", bytes=packet.hex(" "))
                assert P.parse(bytes.fromhex(reply["reply"])) == P.parse(P.status_packet(1, 0))
                time.sleep(0.03)
    finally:
        stop.set()
        poller.join()
    try:
        good = outcomes.count((sdk.COMM_SUCCESS, 0))
        assert len(outcomes) > 50 and good >= 0.9 * len(outcomes), outcomes
        for _ in range(5):
            value, result, error = handler.read1ByteTxRx(port, 1, T.CW_COMPLIANCE_SLOPE)
            if result == sdk.COMM_SUCCESS:
                break
        assert (value, result, error) == (62, sdk.COMM_SUCCESS, 0)
    finally:
        port.closePort()


def test_a_second_emulator_on_the_same_state_directory_runs_without_the_socket(emulator, tmp_path):
    from conftest import EMU, FIRMWARE_DIR
    emulator("--realtime", "--ids", "1", "--state-dir", str(tmp_path))
    second = emulator("--realtime", "--ids", "2", "--state-dir", str(tmp_path))
    assert second.proc.poll() is None
    sock = ax12_control.default_socket_path(str(tmp_path))
    third = subprocess.run([EMU, "serve", "--firmware-dir", FIRMWARE_DIR, "--ids", "3", "--state-dir", str(tmp_path),
                            "--control", sock], capture_output=True, text=True, timeout=30)
    assert third.returncode == 1 and "another running emulator serves it" in third.stderr
    assert "ready:" not in third.stdout
    with ax12_control.Control(sock) as control:
        assert [s["slot"] for s in control.request("status")["servos"]] == [1]
