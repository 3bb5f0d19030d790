# SPDX-License-Identifier: GPL-3.0-or-later
"""`ax12-emu serve --robot` (docs/robot.md) through the real program: its bad input; the robot's
servos on the bus beside others that keep their loads; the robot's world changed while it runs
(`scripts/ax12 world`, the control socket, the dashboard's server); the same traffic at the
same simulated times (--play-bus) giving the same joint trajectories bit for bit, --fast and
--realtime, and with gdb holding a servo in between; the hexapod stood up from a crouch by
DynamixelSDK with SYNC_WRITEs over the pty, holding its height, settling with torque off."""
import asyncio
import json
import os
import shutil
import socket
import subprocess
import time

import aiohttp
import dynamixel_sdk as sdk
import pytest
import serial

import ax12_control
import ax12_table as T
from ax12_packets import instruction_packet as packet
from ax12_servo_port import transact
from conftest import EMU, FIRMWARE_DIR, servo, wait_for, world

ELF = os.path.join(FIRMWARE_DIR, "ax12-ax12-atmega88.elf")
CSV_HEADER = "time_us,end_us,sender,kind,id,code,code_name,params,checksum_ok,collision,line,raw"


def status_of(state_dir):
    with ax12_control.Control(ax12_control.default_socket_path(str(state_dir))) as control:
        return control.request("status")


def write_model(tmp_path, name, custom, joints):
    """An MJCF of two bodies whose joints are given, bound by `custom`."""
    path = tmp_path / (name + ".xml")
    path.write_text('<mujoco><custom>%s</custom><worldbody><body name="a"><joint name="j" %s/>'
                    '<geom size="0.05" mass="0.1"/><body name="b" pos="0.1 0 0"><joint name="k" %s/>'
                    '<geom size="0.05" mass="0.1"/></body></body></worldbody></mujoco>'
                    % (custom, joints[0], joints[1]))
    return str(path)


def bad_model_cases(tmp_path):
    hinge = ('type="hinge"', 'type="hinge"')
    return {
        "does not load": ["--robot", str(tmp_path / "broken.xml")],
        "names no joint 'elbow'": ["--robot", write_model(tmp_path, "missing", '<numeric name="ax12:elbow" data="1"/>', hinge)],
        "both bound to servo 3": ["--robot", write_model(
            tmp_path, "twice", '<numeric name="ax12:j" data="3"/><numeric name="ax12:k" data="3"/>', hinge)],
        "outside the pot's track": ["--robot", write_model(
            tmp_path, "range", '<numeric name="ax12:j" data="1"/>', ('type="hinge" range="-160 160"', 'type="hinge"'))],
        "unknown robot 'walker'": ["--robot", "walker"],
        "its load and its angle are the robot's": ["--robot", "pendulum", "--world", "1:load-torque=0.5"],
        "--log-joints without --robot": ["--log-joints", str(tmp_path / "j.csv")],
        "no client row to play": ["--play-bus", str(tmp_path / "empty.csv")],
    }


@pytest.mark.parametrize("problem", ["does not load", "names no joint 'elbow'", "both bound to servo 3",
                                     "outside the pot's track", "unknown robot 'walker'",
                                     "its load and its angle are the robot's", "--log-joints without --robot",
                                     "no client row to play"])
def test_bad_robot_input_is_one_line_and_exit_2_with_nothing_started(problem, tmp_path):
    (tmp_path / "broken.xml").write_text("<mujoco><worldbody><body></mujoco>")
    (tmp_path / "empty.csv").write_text(CSV_HEADER + "\n")
    state = tmp_path / "state"
    args = bad_model_cases(tmp_path)[problem]
    run = subprocess.run([EMU, "serve", "--firmware-dir", FIRMWARE_DIR, "--state-dir", str(state), "--fast",
                          "--link", str(tmp_path / "tty")] + args, capture_output=True, text=True, timeout=30)
    assert run.returncode == 2, run.stderr
    assert run.stdout == ""
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and problem in lines[0], run.stderr
    assert lines[0].startswith("ax12-emu: ")
    # nothing started: no pty link, no control socket, no servo's state file
    assert not os.path.exists(tmp_path / "tty")
    assert not state.exists() or not [p for p in os.listdir(state) if p.endswith((".sock", ".eeprom"))]


def test_the_robots_servos_join_the_bus_and_the_others_keep_their_loads(emulator, tmp_path):
    emu = emulator("--realtime", "--robot", "pendulum", "--ids", "2", "--load-spring", "2,120",
                   "--state-dir", str(tmp_path))
    with serial.Serial(emu.device, 1000000, timeout=0.5) as port:
        for ident in (1, 2):
            reply = transact(port, packet(ident, T.INST_PING), 6)
            assert len(reply) == 6 and reply[2] == ident, (ident, reply.hex())
    status = status_of(tmp_path)
    assert [s["slot"] for s in status["servos"]] == [2, 1]
    assert servo(status, 1)["joint"] == "horn" and servo(status, 1)["world"]["load"] == "none"
    assert "joint" not in servo(status, 2) and servo(status, 2)["world"]["load"] == "spring"
    # the spring pulls servo 2 (torque off) toward 120 deg; servo 1's shaft is the pendulum's
    wait_for(lambda: abs(servo(status_of(tmp_path), 2)["angle_deg"] - 120.0) < 10.0, 10, "servo 2 at its spring")
    robot = status["robot"]
    assert len(robot["poses"]) == 4 and robot["world"]["gravity"] is True
    # torque off from power-up: the arm falls from horizontal (joint angle 0, 150 deg on the pot)
    wait_for(lambda: servo(status_of(tmp_path), 1)["angle_deg"] - 150.0 < -60.0, 10, "the arm fallen")


def test_the_robots_world_changes_while_it_runs(emulator, tmp_path):
    """A payload makes the held arm droop more; without gravity it returns to the goal; a push
    on the arm with torque off and no gravity swings it; bad changes are refused whole."""
    emu = emulator("--realtime", "--robot", "pendulum", "--state-dir", str(tmp_path))
    with serial.Serial(emu.device, 1000000, timeout=0.5) as port:
        def write(addr, values):
            reply = transact(port, packet(1, T.INST_WRITE, [addr] + values), 6)
            assert len(reply) == 6 and reply[4] & ~T.ERR_CONDITIONS == 0, reply.hex()

        def position():
            reply = transact(port, packet(1, T.INST_READ, [T.PRESENT_POSITION, 2]), 8)
            assert len(reply) == 8, reply.hex()
            return reply[5] | reply[6] << 8

        write(T.GOAL_POSITION, [0, 2])  # 512: horizontal
        write(T.TORQUE_ENABLE, [1])
        time.sleep(1.5)
        held = position()
        assert 500 <= held <= 511
        done = world("--state-dir", str(tmp_path), "--payload", "tip=0.4")
        assert done.returncode == 0, done.stderr
        assert "0.4 kg on tip" in done.stdout
        time.sleep(1.0)
        loaded = position()
        assert loaded < held - 2, (held, loaded)
        done = world("--state-dir", str(tmp_path), "--gravity", "off")
        assert done.returncode == 0 and "gravity off" in done.stdout, done.stderr
        wait_for(lambda: position() >= 510, 5, "the arm back at its goal without gravity")

        # refused whole: nothing changes
        for args, message in ((["--payload", "nowhere=1"], "no body 'nowhere'"),
                              (["--payload", "tip=11"], "a payload is 0..10 kg"),
                              (["--push", "arm=0,0,5000"], "within +-1000 N"),
                              (["--push", "tip=0,0,1,20"], "at most 10 s"),
                              (["--gravity", "on", "--payload", "world=1"], "world body does not move")):
            done = world("--state-dir", str(tmp_path), *args)
            assert done.returncode == 1 and message in done.stderr, (args, done.stderr)
        robot = status_of(tmp_path)["robot"]
        assert robot["world"]["gravity"] is False
        assert robot["world"]["payloads"] == [{"body": "tip", "kg": 0.4}]

        write(T.TORQUE_ENABLE, [0])
        time.sleep(0.3)
        before = servo(status_of(tmp_path), 1)["angle_deg"]
        done = world("--state-dir", str(tmp_path), "--push", "tip=0,0,8,0.3")
        assert done.returncode == 0 and "pushing tip" in done.stdout, done.stderr
        wait_for(lambda: servo(status_of(tmp_path), 1)["angle_deg"] > before + 20.0, 5, "the pushed arm swinging up")
    # the servo's JSON through the command line names its joint
    done = world("--state-dir", str(tmp_path), "--json")
    listing = json.loads(done.stdout)
    assert listing["servos"][0]["joint"] == "horn" and listing["robot"]["world"]["gravity"] is False


def play_file(path, rows):
    """A --log-bus CSV of client packets: rows of (time_us, packet bytes)."""
    with open(path, "w") as f:
        f.write(CSV_HEADER + "\n")
        for t, data in rows:
            f.write("%.4f,%.4f,client,instruction,,,,,1,0,,%s\n" % (t, t + 10 * len(data), data.hex(" ").upper()))


def arm_traffic(path):
    """Torque on, then three sets of goals for the arm's five servos, at fixed simulated times."""
    def sync(addr, size, values):
        params = [addr, size]
        for ident, v in values.items():
            params += [ident] + [(v >> (8 * i)) & 0xFF for i in range(size)]
        return packet(T.ID_BROADCAST, T.INST_SYNC_WRITE, params)

    rows = [(300000.0, sync(T.MOVING_SPEED, 2, {i: 200 for i in range(1, 6)})),
            (301500.0, sync(T.TORQUE_ENABLE, 1, {i: 1 for i in range(1, 6)}))]
    goals = [[600, 430, 600, 500, 560], [420, 560, 450, 600, 470], [512, 512, 512, 512, 512]]
    for k, g in enumerate(goals):
        rows.append((500000.0 + 500000.0 * k, sync(T.GOAL_POSITION, 2, {i + 1: g[i] for i in range(5)})))
        rows.append((520000.0 + 500000.0 * k, packet(3, T.INST_READ, [T.PRESENT_POSITION, 2])))
    play_file(path, rows)


def joint_rows(path, until_us):
    with open(path) as f:
        header = f.readline()
        rows = [line for line in f if line.endswith("\n") and float(line.split(",", 1)[0]) <= until_us]
    return header, rows


def run_to(emulator, tmp_path, name, until_us, *extra, before_stop=None):
    """serve --robot arm --play-bus until its joint log reaches until_us of simulated time."""
    state = tmp_path / ("state-" + name)
    log = tmp_path / (name + ".csv")
    emu = emulator("--robot", "arm", "--state-dir", str(state), "--play-bus", str(tmp_path / "traffic.csv"),
                   "--log-joints", str(log), *extra)
    if before_stop:
        before_stop(emu)

    def reached():
        if not log.exists():
            return False
        with open(log, "rb") as f:
            f.seek(max(0, log.stat().st_size - 4096))
            tail = f.read().splitlines()
        return len(tail) > 1 and float(tail[-2].split(b",", 1)[0]) > until_us

    wait_for(reached, 120, "the joint log at %g s" % (until_us / 1e6))
    assert emu.stop() == 0
    return joint_rows(log, until_us)


def test_the_same_traffic_gives_the_same_joint_trajectories_fast_and_realtime(emulator, tmp_path):
    arm_traffic(tmp_path / "traffic.csv")
    until_us = 2200000.0
    header, fast = run_to(emulator, tmp_path, "fast", until_us, "--fast")
    _, again = run_to(emulator, tmp_path, "again", until_us, "--fast")
    _, realtime = run_to(emulator, tmp_path, "realtime", until_us, "--realtime")
    assert header.strip() == "time_us,base,shoulder,elbow,wrist,gripper"
    assert len(fast) == 2200  # one row a millisecond
    assert fast == again
    assert fast == realtime
    # and the arm moved: the shoulder went to each goal and back
    shoulder = [float(row.split(",")[2]) for row in fast]
    assert max(shoulder) - min(shoulder) > 0.5


def test_a_gdb_hold_stops_the_robot_and_changes_no_trajectory(emulator, tmp_path):
    gdb = shutil.which("avr-gdb")
    if gdb is None:
        pytest.skip("avr-gdb is not installed (Debian package gdb-avr; scripts/setup installs it)")
    arm_traffic(tmp_path / "traffic.csv")
    until_us = 1500000.0
    _, plain = run_to(emulator, tmp_path, "plain", until_us, "--fast")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]

    def hold(emu):
        # gdb attaches (the servo stops, the world with it) for 2 s of wall time, then detaches
        held = subprocess.run([gdb, "-batch", "-nx", "-ex", f"target remote :{port}", "-ex", "shell sleep 2", ELF],
                              capture_output=True, text=True, timeout=60)
        assert held.returncode == 0, held.stderr
    _, debugged = run_to(emulator, tmp_path, "debugged", until_us, "--fast", "--gdb", f"2:{port}", before_stop=hold)
    assert debugged == plain


def test_the_dashboard_serves_the_robot_its_poses_and_world_changes(emulator, tmp_path):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    emulator("--realtime", "--robot", "arm", "--state-dir", str(tmp_path), "--dashboard", str(port))

    async def visit():
        async with aiohttp.ClientSession() as session:
            async with session.get("http://127.0.0.1:%d/api/robot" % port) as response:
                robot = (await response.json())["robot"]
            async with session.ws_connect("http://127.0.0.1:%d/ws" % port) as ws:
                await ws.send_str(json.dumps({"type": "robot", "req": 7, "set": {"gravity": False}}))
                telemetry, result = None, None
                while telemetry is None or result is None:
                    message = json.loads((await ws.receive(timeout=10)).data)
                    if message.get("event") == "telemetry" and "robot" in message:
                        telemetry = message
                    if message.get("event") == "result":
                        result = message
                await ws.send_str(json.dumps({"type": "robot", "req": 8, "set": {"payload": {"body": "x", "kg": 1}}}))
                while True:
                    message = json.loads((await ws.receive(timeout=10)).data)
                    if message.get("event") == "result":
                        refused = message
                        break
        return robot, telemetry, result, refused

    robot, telemetry, result, refused = asyncio.run(visit())
    assert robot["name"] == "arm" and robot["timestep_s"] == 0.001
    names = [b["name"] for b in robot["bodies"]]
    assert names[:3] == ["world", "base", "turret"] and "grip" in names
    servos = {j["name"]: j["servo"] for j in robot["joints"]}
    assert servos == {"base": 1, "shoulder": 2, "elbow": 3, "wrist": 4, "gripper": 5}
    geom = next(g for g in robot["geoms"] if g["name"] == "ax12_3")
    assert geom["type"] == "box" and geom["size"] == [0.016, 0.02, 0.025] and geom["body"] == names.index("upper_arm")
    assert len(telemetry["robot"]["poses"]) == len(names) and len(telemetry["robot"]["poses"][0]) == 7
    assert result["ok"] and result["req"] == 7
    assert not refused["ok"] and "no body 'x'" in refused["message"]
    assert status_of(tmp_path)["robot"]["world"]["gravity"] is False


# ---- the hexapod and DynamixelSDK ----------------------------------------------------------

HEXAPOD_IDS = range(1, 19)
STAND_HEIGHT_BOUND_M = 0.002  # the body's height over 10 s of holding: within 2 mm


def body_height(state_dir):
    robot = status_of(state_dir)["robot"]
    return robot["time_s"], robot["poses"][1][2]


def test_the_hexapod_stands_up_with_dynamixel_sdk_holds_and_settles_with_torque_off(emulator, tmp_path):
    """--fast: simulated time runs free, so no READ waits on the host keeping up with real time
    (scripts/bench measures that); the times below are the robot's, simulated."""
    emu = emulator("--fast", "--robot", "hexapod", "--state-dir", str(tmp_path))
    port = sdk.PortHandler(emu.device)
    assert port.openPort() and port.setBaudRate(1000000)
    handler = sdk.PacketHandler(1.0)

    def sync(addr, size, value):
        group = sdk.GroupSyncWrite(port, handler, addr, size)
        for ident in HEXAPOD_IDS:
            assert group.addParam(ident, [(value >> (8 * i)) & 0xFF for i in range(size)])
        assert group.txPacket() == sdk.COMM_SUCCESS

    def read_position(ident):
        for _ in range(50):  # a READ the pty held past the SDK's timeout (a busy machine: docs/emulator.md "pty limit") is asked again
            try:
                value, result, error = handler.read2ByteTxRx(port, ident, T.PRESENT_POSITION)
            except IndexError:  # DynamixelSDK 4.1.0 takes a late short status of that ID for the reply
                continue
            if result == sdk.COMM_SUCCESS:
                return value
        pytest.fail("servo %d does not answer READ" % ident)

    try:
        _, crouched = body_height(tmp_path)
        assert crouched < 0.025  # the body on the floor
        femurs = [3, 4, 9, 10, 15, 16]
        assert all(abs(read_position(i) - (512 + 60 * 1024 / 300)) <= 3 for i in femurs)  # +60 deg
        sync(T.MOVING_SPEED, 2, 60)
        sync(T.GOAL_POSITION, 2, 512)
        sync(T.TORQUE_ENABLE, 1, 1)
        t0, _ = body_height(tmp_path)
        wait_for(lambda: body_height(tmp_path)[0] > t0 + 3.0, 60, "3 s of standing up")
        heights = []
        t_hold, _ = body_height(tmp_path)
        while True:  # 10 s of simulated time, the controller sending its goals again now and then
            sync(T.GOAL_POSITION, 2, 512)
            t, z = body_height(tmp_path)
            heights.append(z)
            if t > t_hold + 10.0:
                break
            time.sleep(0.05)
        assert len(heights) >= 10
        assert min(heights) > 0.12, heights  # standing: the body's centre 140 mm up at zero droop
        assert max(heights) - min(heights) <= STAND_HEIGHT_BOUND_M, heights
        positions = [read_position(i) for i in HEXAPOD_IDS]
        print("standing: body centre %.4f..%.4f m over %d samples; positions %s" % (
            min(heights), max(heights), len(heights), positions))
        assert all(abs(p - 512) <= 12 for p in positions), positions  # each joint near its goal, drooping
        sync(T.TORQUE_ENABLE, 1, 0)
        t_off, _ = body_height(tmp_path)
        wait_for(lambda: body_height(tmp_path)[0] > t_off + 3.0, 60, "3 s with torque off")
        print("3 s after torque off: body centre %.4f m" % body_height(tmp_path)[1])
        assert body_height(tmp_path)[1] < 0.03  # back on the floor
    finally:
        port.closePort()
    assert emu.stop() == 0
