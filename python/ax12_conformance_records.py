"""The conformance records: what the core's host tests sent and heard, one JSON object per test
case (test/core/conformance_log.h), read by running the built test executables.

Two users: scripts/conformance renders them as docs/conformance.md, and scripts/ax12_conform.py
replays them against a device on a serial port. Both get the records from here, so the
document and the tool always describe the same cases.

A record: profile, group ("reply matrix", "write ranges", "error paths", "conversations"),
name, rule, facts, steps. Steps have a kind: "bus" (the servos a round starts from: ids, baud
register, temperature), "exchange" (role "given" or "when", sent and heard bytes as hex,
"changes" to the control table; "via" when handed to the core's API without a bus),
"power-cycle", "master-baud" (baud register) and "event" (a condition set inside the servo).

Standard library only.
"""
import json
import os
import subprocess
import tempfile

PROFILES = ("ax12", "ax12a")
EXECUTABLES = ("core_servo", "core_conversations")
GROUPS = ("reply matrix", "write ranges", "error paths", "conversations")


class RecordsError(Exception):
    """The records could not be made; the message says why (and output holds a failing test's
    own output, when there is one)."""

    def __init__(self, message, output=""):
        super().__init__(message)
        self.output = output


def core_dir(build):
    """The folder of the core test executables: <build>/test/core, or build itself."""
    core = os.path.join(build, "test", "core")
    return core if os.path.isdir(core) else build


def run_tests(build, profiles=PROFILES, executables=EXECUTABLES):
    """Runs the core tests of each profile with AX12_CONFORMANCE_LOG set and returns their
    records, in the order the tests wrote them (profile by profile). Raises RecordsError when an
    executable is missing, fails, or writes no or a broken log: the records are only made from
    passing tests."""
    core = core_dir(build)
    records = []
    with tempfile.TemporaryDirectory(prefix="ax12-conformance-") as tmp:
        for profile in profiles:
            for exe in executables:
                path = os.path.join(core, "%s_%s" % (exe, profile))
                if not os.access(path, os.X_OK):
                    raise RecordsError("%s not found; build the host tests first (cmake --build %s)" % (path, build))
                log = os.path.join(tmp, "%s_%s.jsonl" % (exe, profile))
                env = dict(os.environ, AX12_CONFORMANCE_LOG=log)
                proc = subprocess.run([path], cwd=core, env=env, stdout=subprocess.PIPE,
                                      stderr=subprocess.STDOUT, universal_newlines=True)
                if proc.returncode != 0:
                    raise RecordsError("%s failed (exit %d); the reference is only made from passing tests"
                                       % (os.path.basename(path), proc.returncode), proc.stdout)
                if not os.path.exists(log):
                    raise RecordsError("%s wrote no conformance log" % os.path.basename(path))
                with open(log, encoding="utf-8") as f:
                    for number, line in enumerate(f, 1):
                        try:
                            record = json.loads(line)
                        except ValueError as e:
                            raise RecordsError("%s line %d: %s" % (log, number, e))
                        if record.get("truncated"):
                            raise RecordsError("the record of '%s' was truncated" % record.get("name"))
                        records.append(record)
    return records


def parse_hex(text):
    """'FF FF 01' -> [255, 255, 1]; '' -> []."""
    return [int(b, 16) for b in text.split()] if text else []


def exchanges(record, role=None):
    """The exchange steps of a record (of one role when given)."""
    return [s for s in record["steps"] if s["kind"] == "exchange" and (role is None or s["role"] == role)]


def when_exchange(record):
    """The last checked exchange of a record: the one a reply-matrix or write-range cell shows."""
    return exchanges(record, "when")[-1]


def split_rounds(steps):
    """[(bus step or None, [steps])]: a new round at every bus a test starts from."""
    rounds = []
    for step in steps:
        if step["kind"] == "bus":
            rounds.append((step, []))
        else:
            if not rounds:
                rounds.append((None, []))
            rounds[-1][1].append(step)
    return rounds
