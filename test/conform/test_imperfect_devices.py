# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 conform` against imperfect devices: each failure mode a device builder meets,
played by a device on the emulated bus, and the report checked for what a builder needs to act.

The devices are builds of test/conform/foreign_servo.c, a servo written apart from the
firmware and run with `serve --mcu atmega328p --elf` (no bootloader, no .mmcu section), one
defect each (test/conform/CMakeLists.txt): `own-items` cannot hold the AX-12's angle limits,
`deaf` ignores the bus for 3 s after a Protocol 2.0 header, `ignore-rdt` answers at once,
`leaky` takes any value into the RAM area, `ro-hole` lets a 2-byte WRITE change a read-only
item, `half-drop` drops a 1-byte WRITE into a 2-byte item; `plain` has none of them.

- Nothing compared is not a pass: exit 5, "NOTHING COMPARED", the flag that runs the cases.
- A starting-state conflict: named once with its items; exactly the cases that read or write
  them (derived here from the records) are not compared, every other case runs.
- A device silent for seconds: found again, the silence and the case it cost named, the run
  goes on; with a short --silence-wait it stops with the reason.
- Every difference of every failed case is in stdout and in the Markdown report.
- An ignored Return Delay Time is flagged from the emulator's bus; the same cases on the
  plain device are not; over the pty alone the tool gives no verdict and says why.
- A leaked value is named by address where it leaked, and again (with the case that left it)
  where a later case reads it.
"""
import os
import re
import sys

import pytest

import ax12_packets as P
import ax12_table as T
from conftest import R, foreign, records, run_report

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                                "test", "support"))
import doc_samples  # noqa: E402


def blocks(stdout):
    """The failures section of the summary: {"group / name": [its lines]}."""
    out, current = {}, None
    section = stdout.split("failures (every difference):", 1)
    if len(section) < 2:
        return out
    for line in section[1].splitlines():
        if line.startswith("- "):
            current = line[2:]
            out[current] = []
        elif line.startswith("    ") and current:
            out[current].append(line.strip())
        elif not line.strip():
            current = None
    return out


def needles(d):
    """What a report must show of one difference: its step, and its bytes and every byte it
    names, or its words."""
    out = ["%s: " % d["step"]]
    if "heard" in d:
        out += [d["sent"], d["heard"] or "silence"] + [f["field"] for f in d.get("bytes") or ()]
    else:
        out.append(d["note"])
    return out


def assert_every_difference_reported(stdout, markdown, report):
    text = blocks(stdout)
    rows = {tuple(line.split(" | ")[:2]): line for line in markdown.splitlines() if line.startswith("| ")}
    failed = [c for c in report["cases"] if c["status"] == "failed"]
    assert failed
    for c in failed:
        key = "%s / %s" % (c["group"], c["name"])
        assert key in text, key
        shown = "\n".join(text[key])
        row = rows[("| " + c["group"], c["name"])]
        assert c["differences"]
        for d in c["differences"]:
            for needle in needles(d):
                assert needle in shown, (key, needle, shown)
                assert needle in row, (key, needle, row)


def case(report, name):
    found = [c for c in report["cases"] if c["name"] == name]
    assert len(found) == 1, name
    return found[0]


# --- nothing compared -----------------------------------------------------------------------------

def test_a_run_that_compares_nothing_is_not_a_pass(serve, tmp_path):
    emu = serve()
    proc, report = run_report(tmp_path, emu, "--case", "Baud Rate", eeprom=False)
    eeprom_skips = report["skipped_reasons"].get("eeprom", 0)
    assert proc.returncode == 5, proc.stdout + proc.stderr
    assert report["result"] == "NOTHING COMPARED" and report["totals"]["passed"] == report["totals"]["failed"] == 0
    assert eeprom_skips > 0
    assert ("result: NOTHING COMPARED: every case was skipped; --allow-eeprom would run %d of them" % eeprom_skips
            in proc.stdout), proc.stdout
    # the flag it names runs them
    proc, report = run_report(tmp_path, emu, "--case", "Baud Rate")
    assert proc.returncode == 0 and report["totals"]["passed"] == eeprom_skips, proc.stdout


# --- a starting-state conflict --------------------------------------------------------------------

OWN = set(range(6, 10))  # where the device keeps its own items: the AX-12's angle limits
NEEDS_LIMITS = set(range(T.GOAL_POSITION, T.MOVING_SPEED + 2))  # their replies carry the Angle Limit bit


def touches_the_angle_limits(record):
    """A record whose exchanges read or write addresses 6..9, or write a goal or a speed."""
    for s in record["steps"]:
        if s["kind"] != "exchange":
            continue
        packet = P.parse(R.parse_hex(s["sent"]))
        if packet is None:
            continue
        instruction, params = packet.code, packet.params
        if instruction == T.INST_READ and len(params) == 2 and OWN & set(range(params[0], params[0] + params[1])):
            return True
        if instruction in (T.INST_WRITE, T.INST_REG_WRITE) and len(params) >= 2:
            if (OWN | NEEDS_LIMITS) & set(range(params[0], params[0] + len(params) - 1)):
                return True
        if instruction == T.INST_SYNC_WRITE and len(params) >= 2:
            if (OWN | NEEDS_LIMITS) & set(range(params[0], params[0] + params[1])):
                return True
    return False


def test_a_starting_state_conflict_is_named_once_and_every_other_case_runs(serve, tmp_path):
    emu = serve(extra=foreign("own-items"))
    proc, report = run_report(tmp_path, emu, "--only", "matrix", "--only", "ranges")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert {(c["address"], c["item"]) for c in report["conflicts"]} == {(6, "CW Angle Limit"), (8, "CCW Angle Limit")}
    assert proc.stdout.count("CW Angle Limit (address 6) = 0:") == 1, proc.stdout
    assert proc.stdout.count("CCW Angle Limit (address 8) = 1023:") == 1, proc.stdout
    wanted = {(r["group"], r["name"]) for r in records("ax12") if r["group"] in ("reply matrix", "write ranges")}
    need_limits = {(r["group"], r["name"]) for r in records("ax12") if touches_the_angle_limits(r)} & wanted
    not_compared = {(c["group"], c["name"]) for c in report["cases"] if c["skip"] == "conflict"}
    replayable = {(c["group"], c["name"]) for c in report["cases"] if c["status"] != "skipped" or c["skip"] == "conflict"}
    assert not_compared == need_limits & replayable
    assert sum(len(c["cases"]) for c in report["conflicts"]) >= len(not_compared) > 0
    # every other case ran, and none was charged with the conflict
    for c in report["cases"]:
        if (c["group"], c["name"]) in replayable - not_compared:
            assert c["status"] in ("passed", "failed"), c
            assert not any("starting state" in d["note"] or "preparation" in d["step"] for d in c["differences"]), c
    assert case(report, "WRITE of LED = 1 (max) is accepted")["status"] == "passed"
    assert case(report, "PING to its own ID at Status Return Level 2")["status"] == "passed"
    assert "refused the starting state" not in proc.stdout


# --- a silent device ------------------------------------------------------------------------------

def test_a_device_silent_for_seconds_is_found_and_the_run_goes_on(serve, tmp_path):
    emu = serve(extra=foreign("deaf"))
    selection = ("--case", "protocol2_frames", "--case", "status_return_level")
    proc, report = run_report(tmp_path, emu, *selection)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert len(report["silences"]) == 1, report["silences"]
    silence = report["silences"][0]
    assert silence["case"] == "conversations / protocol2_frames.conv" and silence["found"] == {"id": 1, "bps": 1000000}
    assert silence["seconds"] >= 2.5, silence  # the device is deaf for 3 s
    assert "- during 'conversations / protocol2_frames.conv', " in proc.stdout
    p2 = case(report, "protocol2_frames.conv")
    assert p2["status"] == "failed" and any(d.get("silence") for d in p2["differences"])
    later = [c for c in report["cases"] if "status_return_level" in c["name"]]
    assert later and all(c["status"] == "passed" for c in later), later  # nothing charged to them
    assert not report["stopped"] and report["restored"]

    # a wait shorter than the silence: the run stops, says why, and runs nothing more
    proc, report = run_report(tmp_path, emu, *selection, "--silence-wait", "0.5")
    assert report["stopped"] and "protocol2_frames.conv" in report["stopped"], report["stopped"]
    assert "stopped: the device went silent during 'protocol2_frames.conv'" in proc.stdout
    assert all(c["status"] == "not run" for c in report["cases"] if "status_return_level" in c["name"])
    assert proc.returncode == (4 if report["restore_problems"] else 1), proc.stdout + proc.stderr


# --- every difference ----------------------------------------------------------------------------

@pytest.mark.parametrize("device", ["leaky", "half-drop"])
def test_every_difference_of_a_case_is_in_every_report(serve, tmp_path, device):
    emu = serve(extra=foreign(device))
    md = tmp_path / "report.md"
    proc, report = run_report(tmp_path, emu, "--case", "One byte of a 16 bit item", "--case", "range_error",
                              "--case", "byte of Goal Position", "--report", md)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert_every_difference_reported(proc.stdout, md.read_text(), report)
    one_byte = case(report, "One byte of a 16 bit item is checked as the resulting value")
    if device == "leaky":
        # it takes 04 into the high bytes of Goal Position and Punch: two replies and the table differ
        assert [d["step"] for d in one_byte["differences"]] == ["step 2", "step 5", "table after"], one_byte
        assert "Punch (addresses 48-49) 32 expected, 1056 read" in one_byte["differences"][-1]["note"]
    else:
        # it answers a one-byte write into a 16-bit item and drops it: only the table tells
        dropped = case(report, "WRITE of the low byte of Goal Position = FF alone (767) is accepted")
        assert [d["note"] for d in dropped["differences"]] == ["Goal Position (addresses 30-31) 767 expected, 512 read"]


# --- Return Delay Time ---------------------------------------------------------------------------

@pytest.mark.parametrize("device,ignores", [("ignore-rdt", True), ("plain", False)])
def test_an_ignored_return_delay_time_is_caught_on_the_bus(serve, tmp_path, device, ignores):
    emu = serve(extra=foreign(device))
    selection = ("--only", "matrix", "--case", "to its own ID")
    proc, report = run_report(tmp_path, emu, *selection, eeprom=False)
    timed = [(c, r) for c in report["cases"] for r in c["replies"]]
    assert timed and all(r["bus_start_us"] is not None for _, r in timed)
    tm = report["timing"]
    assert tm["source"] == "bus" and tm["replies"] == len(timed)
    if ignores:
        # answered within tens of us where 500 us are due: every reply early, each case that
        # has one failed with it, the summary says how many
        assert all(r["bus_start_us"] < 200 and r.get("flag") == "early" for _, r in timed), timed
        assert tm["early"] == len(timed) and "%d early (by over 1 us)" % len(timed) in proc.stdout
        for c, r in timed:
            assert c["status"] == "failed" and any(
                d["step"] == r["step"] and "Return Delay Time 250 asks for 500 us" in d["note"] for d in c["differences"])
        assert proc.returncode == 1
    else:
        assert all(abs(r["bus_start_us"] - r["return_delay_us"]) < 150 and "flag" not in r for _, r in timed), timed
        assert tm["early"] == tm["late"] == 0 and proc.returncode == 0, proc.stdout
    # over the pty alone: the wall clock gives no verdict, and the summary says so
    proc, report = run_report(tmp_path, emu, *selection, eeprom=False, bus=False)
    assert report["timing"]["source"] == "port" and report["timing"]["early"] == 0
    assert "no verdict on Return Delay Time" in proc.stdout
    assert not any("Return Delay Time 250 asks" in d["note"] for c in report["cases"] for d in c["differences"])


# --- leaks ---------------------------------------------------------------------------------------

def test_a_leaked_value_is_named_by_address_where_it_leaked_and_where_it_is_undone(serve, tmp_path):
    emu = serve(extra=foreign("leaky"))
    proc, report = run_report(tmp_path, emu, "--case", "Lock =")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    leak = case(report, "WRITE of Lock = 2 (max+1) is a Range Error")
    assert [d["note"] for d in leak["differences"]] == [
        "error byte: expected 08 (range), heard 00 (no error)", "Lock (address 47) 0 expected, 2 read"]
    after = case(report, "WRITE of Lock = 255 (all ones) is a Range Error")
    assert ("preparation: address 47 (Lock) read 2, left by 'write ranges / WRITE of Lock = 2 (max+1) is a Range "
            "Error'; written back") in after["notes"], after


def test_a_read_only_item_that_yields_to_a_wider_write_is_caught_and_its_leak_named(serve, tmp_path):
    emu = serve(extra=foreign("ro-hole"))
    md = tmp_path / "report.md"
    proc, report = run_report(tmp_path, emu, "--case", "at 0 (Model Number)", "--case", "Read of the whole table",
                              "--report", md)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    wide = [c for c in report["cases"] if c["name"].startswith("WRITE of 2 bytes") and "at 0 (Model Number)" in c["name"]]
    narrow = [c for c in report["cases"] if c["name"].startswith("WRITE of 1 byte") and "at 0 (Model Number)" in c["name"]]
    assert len(wide) == 2 and all(c["status"] == "failed" for c in wide)
    assert len(narrow) == 2 and all(c["status"] == "passed" for c in narrow)
    for c in wide:
        assert c["differences"][0]["note"] == "error byte: expected 08 (range), heard 00 (no error)", c
        assert re.match(r"Model Number \(addresses 0-1\) \d+ expected, \d+ read", c["differences"][1]["note"]), c
    last_wide = "write ranges / " + wide[-1]["name"]
    read = case(report, "Read of the whole table and of its last byte")
    named = [f for d in read["differences"] for f in d.get("bytes") or ()]
    assert {f["address"] for f in named} >= {0, 1}, read
    assert all(f["left_by"] == last_wide for f in named if f["address"] in (0, 1)), named
    assert "address 0 (Model Number, low byte): expected 0C, heard FF (left by '%s')" % last_wide in proc.stdout
    assert_every_difference_reported(proc.stdout, md.read_text(), report)


# --- docs/conform.md's sample ----------------------------------------------------------------------

def conform_many_line(line):
    """A summary line with what no two runs share masked: the pty and the socket's paths, the
    timings (the device answers when its loop comes round, which real time places) and the
    length of a silence."""
    line = re.sub(r"^ax12 conform: \S+ \(pty\)", "ax12 conform: PORT (pty)", line)
    line = re.sub(r"control socket \S+\)", "control socket SOCK)", line)
    line = re.sub(r"[-+]?\d+\.\d+( us|\.\.)", r"T\1", line)
    line = re.sub(r"median [-+]?\d+\.\d+", "median T", line)
    line = re.sub(r"\d+\.\d+ s\b", "S s", line)
    return line


def test_the_many_defect_device_reports_as_docs_conform_shows(serve, tmp_path):
    """`foreign-many` (every defect above at once) through the whole suite, on the emulator's bus:
    the summary docs/conform.md shows, case counts, conflicts, silence and failures."""
    emu = serve(extra=foreign("many"))
    proc, report = run_report(tmp_path, emu)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    doc_samples.check("conform-many-defects", proc.stdout, normalize=conform_many_line)
