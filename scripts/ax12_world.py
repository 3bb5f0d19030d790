#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 world`: shows or changes the physical world of servos in a running
`scripts/ax12 serve` (supply, air temperature, the load on the output), and of its robot
(`serve --robot`: a payload on a body, a push on a body, gravity), through its control socket
(docs/dashboard.md, docs/robot.md). The names and ranges are those of serve's world options.

  scripts/ax12 world                              every servo's world and readings (and the robot's)
  scripts/ax12 world --servo 3 --load-torque 1.2  servo 3 (as in --ids) under 1.2 N m
  scripts/ax12 world --servo all --supply 7       every servo at 7 V
  scripts/ax12 world --servo 3 --load-none        servo 3 unloaded
  scripts/ax12 world --payload tip=0.3            0.3 kg on the robot's body "tip" (0 removes it)
  scripts/ax12 world --push body=0,20,0,0.2       20 N along +y on body "body" for 0.2 s
  scripts/ax12 world --gravity off                the robot without gravity (on: back)

Exit status: 0 done; 1 the emulator refused the change (nothing changed, its reason printed);
2 bad arguments; 3 no emulator answers on the control socket.
"""
import argparse
import json
import os
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "python"))

import ax12_control  # noqa: E402

EXIT_REFUSED, EXIT_USAGE, EXIT_NO_EMULATOR = 1, 2, 3
CHANGES = ("supply", "ambient", "load-torque", "load-spring", "load-arm")


def describe_world(world):
    load = world["load"]
    if load == "torque":
        load = "constant torque %g N m" % world["load_torque_nm"]
    elif load == "spring":
        load = "spring %g N m/rad toward %g deg" % (world["spring_nm_rad"], world["rest_deg"])
    elif load == "arm":
        load = "arm %g kg at %g m, horizontal at %g deg" % (world["mass_kg"], world["arm_m"], world["horizontal_deg"])
    else:
        load = "no load"
    return "supply %g V, ambient %g degC, %s" % (world["supply"], world["ambient"], load)


def describe_servo(s):
    line = "servo %d: %s" % (s["slot"], describe_world(s["world"]))
    if "joint" in s:
        line = "servo %d: joint '%s' of the robot, supply %g V, ambient %g degC" % (
            s["slot"], s["joint"], s["world"]["supply"], s["world"]["ambient"])
    if "angle_deg" in s:
        line += ("\n  now: %.1f deg, %.1f rpm, duty %+.2f, motor %.2f A, winding %.1f degC, case %.1f degC, "
                 "%.2f V at the connector, load torque %+.2f N m"
                 % (s["angle_deg"], s["speed_rpm"], s["duty"], s["motor_current_a"], s["winding_c"], s["case_c"],
                    s["supply_v"], s["load_torque_nm"]))
    if "id" in s:
        line += "\n  firmware: ID %d, Present Position %d, Present Load %d, torque %s, alarm conditions 0x%02X" % (
            s["id"], s["present_position"], s["present_load"], "on" if s["torque_enable"] else "off", s["conditions"])
    return line


def parse_payload(text):
    body, sep, kg = text.rpartition("=")
    try:
        if not sep or not body:
            raise ValueError
        return {"body": body, "kg": float(kg)}
    except ValueError:
        raise ValueError("--payload %r: BODY=KG, e.g. tip=0.3" % text) from None


def parse_push(text):
    body, sep, values = text.rpartition("=")
    try:
        numbers = [float(v) for v in values.split(",")]
        if not sep or not body or len(numbers) not in (3, 4):
            raise ValueError
    except ValueError:
        raise ValueError("--push %r: BODY=FX,FY,FZ[,SECONDS], e.g. body=0,20,0,0.2" % text) from None
    return {"body": body, "force_n": numbers[:3], "seconds": numbers[3] if len(numbers) == 4 else 0.1}


def describe_robot(robot):
    world = robot["world"]
    payloads = ", ".join("%g kg on %s" % (p["kg"], p["body"]) for p in world["payloads"]) or "no payload"
    pushes = "".join("; pushing %s with %s N for %.3f s more" % (p["body"], p["force_n"], p["seconds_left"])
                     for p in world["pushes"])
    return "robot at %.3f s: gravity %s, %s%s" % (robot["time_s"], "on" if world["gravity"] else "off", payloads,
                                                 pushes)


def main():
    parser = argparse.ArgumentParser(prog="scripts/ax12 world", description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--servo", default="all", help="a servo's ID as given to serve's --ids, or 'all' (default)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--state-dir", help="serve's --state-dir (default: serve's default); the socket is "
                                           "<state-dir>/control.sock")
    where.add_argument("--control", help="serve's --control socket path")
    parser.add_argument("--supply", metavar="VOLTS", help="supply voltage at the source, 0.1..30")
    parser.add_argument("--ambient", metavar="CELSIUS", help="air temperature, -40..150")
    load = parser.add_mutually_exclusive_group()
    load.add_argument("--load-torque", metavar="NM", help="constant torque on the output, -10..10 N m (+ = CCW)")
    load.add_argument("--load-spring", metavar="K[,REST_DEG]", help="spring of K N m/rad toward REST_DEG")
    load.add_argument("--load-arm", metavar="KG,METRES[,HORIZONTAL_DEG]", help="a mass on an arm under gravity")
    load.add_argument("--load-none", action="store_true", help="no load")
    robot = parser.add_argument_group("the robot (serve --robot)")
    robot.add_argument("--payload", metavar="BODY=KG", action="append", default=[],
                       help="a payload of KG (0..10) at the centre of mass of the robot's body BODY, replacing the "
                            "one there; 0 removes it (repeatable)")
    robot.add_argument("--push", metavar="BODY=FX,FY,FZ[,SECONDS]", action="append", default=[],
                       help="a force in newtons (world frame, z up) on body BODY's centre of mass for SECONDS "
                            "(default 0.1) of simulated time (repeatable)")
    robot.add_argument("--gravity", choices=("on", "off"), help="gravity on the robot")
    parser.add_argument("--json", action="store_true", help="print the emulator's answer as JSON")
    args = parser.parse_args()
    robot_changes = {}
    try:
        if args.payload:
            robot_changes["payload"] = [parse_payload(text) for text in args.payload]
        if args.push:
            robot_changes["push"] = [parse_push(text) for text in args.push]
    except ValueError as e:
        parser.error(str(e))
    if args.gravity:
        robot_changes["gravity"] = args.gravity == "on"

    if args.servo == "all":
        servo = "all"
    else:
        try:
            servo = int(args.servo)
        except ValueError:
            parser.error("--servo: an ID (as in serve's --ids) or 'all'")
    changes = {}
    for name in CHANGES:
        value = getattr(args, name.replace("-", "_"))
        if value is not None:
            changes[name] = value
    if args.load_none:
        changes["load-none"] = True

    path = args.control or ax12_control.default_socket_path(args.state_dir)
    try:
        with ax12_control.Control(path) as control:
            fields = {"id": servo}
            if changes:
                fields["set"] = changes
            if robot_changes:  # the robot's changes are checked as a whole too, before the servos'
                control.request("robot", set=robot_changes)
            if changes or not robot_changes:
                control.request("world", **fields)  # refused as a whole, before the status below
            status = control.request("status")
    except ax12_control.ControlError as e:
        refused = "cannot reach" not in str(e)
        print("ax12 world: %s" % e, file=sys.stderr)
        return EXIT_REFUSED if refused else EXIT_NO_EMULATOR
    servos = [s for s in status["servos"] if servo == "all" or s["slot"] == servo]
    robot = status.get("robot")
    if args.json:
        print(json.dumps({"servos": servos, "robot": robot} if robot else servos, indent=2))
    else:
        for s in servos:
            print(describe_servo(s))
        if robot:
            print(describe_robot(robot))
    return 0


if __name__ == "__main__":
    sys.exit(main())
