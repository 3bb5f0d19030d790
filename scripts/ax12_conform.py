#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Checks a Dynamixel Protocol 1.0 device on a serial port against the AX-12 conformance suite
(`scripts/ax12 conform`; docs/conform.md). This file is the command line; the work is done by
python/ax12_conform_*.py: the device connection (device), the cases (cases, rewrite), the
runner (runner, keeper), the timing (timing, bus_clock) and the report (report).

The cases are the conformance records of the core's host tests (the reply matrix, the write
ranges, the error paths and the conversations of test/conversations): the records
docs/conformance.md is rendered from. Each is replayed against the device with its IDs and
bauds rewritten; every reply must come back byte for byte but for the present values; after
each case the table is read back. Safe by default: cases that would write the EEPROM area need
--allow-eeprom, and every setting changed is written back, also after Ctrl-C or SIGTERM.

Exit status: 0 every case compared passed; 1 a case failed, the device would not take a
starting state, or was lost; 2 bad arguments, no port, no device; 3 refused (two devices at
the ID, device locked); 4 a setting could not be restored; 5 nothing compared (every case
skipped: the summary names the flag that would run them); 130 interrupted (settings restored).
"""
import argparse
import os
import signal
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "python"))

EXIT_FAILED, EXIT_USAGE, EXIT_REFUSED, EXIT_RESTORE, EXIT_NOTHING, EXIT_INTERRUPTED = 1, 2, 3, 4, 5, 130

GROUP_NAMES = {"matrix": "reply matrix", "reply matrix": "reply matrix", "ranges": "write ranges",
               "write ranges": "write ranges", "errors": "error paths", "error paths": "error paths",
               "conversations": "conversations"}


# --- arguments -----------------------------------------------------------------------------------

def arguments(argv):
    p = argparse.ArgumentParser(prog="scripts/ax12 conform", description=__doc__.split("\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="See docs/conform.md for what is compared and how the device is kept safe.")
    p.add_argument("--port", required=True, help="the serial device (e.g. /dev/ttyUSB0, or the pty of scripts/ax12 serve)")
    p.add_argument("--id", type=int, default=1, help="the device's ID (default 1)")
    p.add_argument("--baud", type=int, default=1000000,
                   help="the device's baud: bit/s, or a Baud Rate register value 0..254 (default 1000000)")
    p.add_argument("--profile", choices=("ax12", "ax12a"), default="ax12",
                   help="which AX-12 to compare with: ax12 (2006 manual, default) or ax12a")
    p.add_argument("--only", action="append", default=[], metavar="GROUP",
                   help="run one group: matrix, ranges, errors, conversations (repeatable)")
    p.add_argument("--case", action="append", default=[], metavar="TEXT",
                   help="run only cases whose name contains TEXT (repeatable)")
    p.add_argument("--allow-eeprom", action="store_true",
                   help="also run cases that write the EEPROM area, the ID or the baud (restored afterwards)")
    p.add_argument("--report", action="append", default=[], metavar="FILE",
                   help="write a report: FILE.md (Markdown) or FILE.json (machine-readable); repeatable")
    p.add_argument("--timeout", type=float, default=0.05,
                   help="seconds to wait for a reply after a request has left (default 0.05; "
                        "raise it for USB adapters with a long latency timer)")
    p.add_argument("--emulator", metavar="SOCKET",
                   help="the control socket of the `scripts/ax12 serve` behind --port (<state-dir>/control.sock): "
                        "each reply's start is taken from its bus, exactly (default: that of the default state "
                        "directory, when it serves --port)")
    p.add_argument("--silence-wait", type=float, default=10.0, metavar="SECONDS",
                   help="how long a device that went silent is looked for before the run stops (default 10)")
    p.add_argument("--build", default=os.path.join(REPO, "build"),
                   help="the build holding the core tests the cases come from (default build/)")
    p.add_argument("--verbose", "-v", action="store_true", help="print every exchange to stderr as it happens")
    args = p.parse_args(argv)
    if not 0 <= args.id <= 253:
        p.error("--id must be 0..253")
    if 0 <= args.baud <= 254:
        args.baud_register = args.baud
    elif args.baud >= 7843:
        args.baud_register = max(0, min(254, round(2000000 / args.baud) - 1))
    else:
        p.error("--baud: give bit/s (7843..2000000) or a Baud Rate register value (0..254)")
    for g in args.only:
        if g.lower() not in GROUP_NAMES:
            p.error("--only: unknown group '%s' (matrix, ranges, errors, conversations)" % g)
    if args.timeout <= 0:
        p.error("--timeout must be positive")
    if args.silence_wait < 0:
        p.error("--silence-wait must not be negative")
    for r in args.report:
        if not (r.endswith(".md") or r.endswith(".json")):
            p.error("--report: the file name must end in .md or .json: %s" % r)
    return args


ARGS = arguments(sys.argv[1:])
import ax12_build  # noqa: E402
ax12_build.use(ARGS.build)
import serial  # noqa: E402  (pyserial)
import ax12_conformance_records as R  # noqa: E402
from ax12_conform_bus_clock import BusClockError  # noqa: E402
from ax12_conform_device import Problem  # noqa: E402
from ax12_conform_report import summarise, text_summary, write_reports  # noqa: E402
from ax12_conform_runner import Conform, Interrupted, Refused  # noqa: E402


def load_records(args):
    try:
        records = R.run_tests(os.path.abspath(args.build), (args.profile,))
    except R.RecordsError as e:
        raise Problem("the cases come from the core tests: %s" % e)
    groups = {GROUP_NAMES[g.lower()] for g in args.only}
    out = []
    for r in records:
        if groups and r["group"] not in groups:
            continue
        if args.case and not any(t.lower() in r["name"].lower() for t in args.case):
            continue
        out.append(r)
    if not out:
        raise Problem("no case matches --only/--case")
    return out


def on_signal(signum, frame):
    raise Interrupted(signal.Signals(signum).name)


def main():
    args = ARGS
    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    conform = Conform(args)
    interrupted = False
    try:
        try:
            records = load_records(args)
            conform.run(records)
        except Interrupted as e:
            interrupted = True
            print("ax12 conform: interrupted (%s): restoring the device's settings" % e, file=sys.stderr)
        finally:
            # nothing interrupts the restoring
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
            restored = conform.finish()
    except Refused as e:
        print("ax12 conform: refused: %s" % e, file=sys.stderr)
        return EXIT_REFUSED
    except (Problem, BusClockError, OSError, serial.SerialException) as e:
        if isinstance(e, BusClockError):
            print("ax12 conform: the emulator's bus clock (--emulator) failed: %s" % e, file=sys.stderr)
        elif isinstance(e, Problem):
            print("ax12 conform: %s" % e, file=sys.stderr)
        else:
            print("ax12 conform: the port %s failed: %s (did the device, its adapter or the emulator behind "
                  "it go away?)" % (args.port, e), file=sys.stderr)
        if conform.restore_problems:
            for p in conform.restore_problems:
                print("ax12 conform: NOT RESTORED: %s" % p, file=sys.stderr)
            return EXIT_RESTORE
        return EXIT_USAGE
    summary = summarise(conform, interrupted)
    print(text_summary(summary))
    write_reports(summary, args.report)
    if conform.port:
        conform.port.close()
    if conform.timer and conform.timer.clock:
        conform.timer.clock.close()
    if not restored:
        return EXIT_RESTORE
    return {"INTERRUPTED": EXIT_INTERRUPTED, "FAIL": EXIT_FAILED, "NOTHING COMPARED": EXIT_NOTHING}.get(
        summary["result"], 0)


if __name__ == "__main__":
    sys.exit(main())
