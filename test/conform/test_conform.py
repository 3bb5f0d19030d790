# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 conform` (scripts/ax12_conform.py) against `ax12-emu serve`.

- The matching profile: every case run passes, the JSON report has its schema, and the reply
  timing taken from the emulator's bus (--emulator) has no reply early or late.
- The other profile: the failing cases are exactly those whose records differ between the
  profiles (derived here from the two profiles' records and the generated table, not from the
  tool's logic).
- Two deliberately broken firmware builds (test/conform/CMakeLists.txt): the failing cases are
  exactly those the defect touches, derived from the records (facts, bytes and changes).
- Ctrl-C in the middle of an EEPROM case: after a restart of the emulator the device reads its
  original settings.
- Two devices at one ID (a fake device on a pty: the emulator refuses `--ids 1,1`): refused.
- Bad input: a clear message and a non-zero exit, never a traceback.

Devices that are imperfect in other ways: test_imperfect_devices.py. Shared fixtures: conftest.py.
"""
import json
import os
import pty
import re
import select
import signal
import subprocess
import sys
import threading
import time
import tty

import pytest

import ax12_packets as P
import ax12_table as T
from ax12_servo_port import transact
from conftest import BUILD, DEFECTS, R, TOOL, conform, failing, ran, records, run_report

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "support"))
import doc_samples  # noqa: E402


def hexes(text):
    return R.parse_hex(text)


# --- the matching profile ------------------------------------------------------------------------

def check_schema(report):
    for key, kind in (("port", str), ("id", int), ("baud_register", int), ("profile", str), ("groups", list),
                      ("totals", dict), ("skipped_reasons", dict), ("restored", bool), ("restore_problems", list),
                      ("warnings", list), ("interrupted", bool), ("cases", list), ("device", dict)):
        assert isinstance(report[key], kind), key
    for g in report["groups"]:
        assert set(g) == {"group", "passed", "failed", "skipped", "not_run"}
        assert g["group"] in R.GROUPS
    assert sum(g["passed"] + g["failed"] + g["skipped"] + g["not_run"] for g in report["groups"]) == len(report["cases"])
    for c in report["cases"]:
        assert c["status"] in ("passed", "failed", "skipped", "not run")
        assert isinstance(c["differences"], list) and isinstance(c["replies"], list)
        if c["status"] == "skipped":
            assert c["reason"]
        if c["status"] == "failed":
            assert c["differences"]
        for d in c["differences"]:
            assert "step" in d and d["note"]
        for r in c["replies"]:
            assert {"step", "start_us", "return_delay_us", "late"} <= set(r) <= {
                "step", "start_us", "return_delay_us", "late", "bus_start_us", "flag"}
    tm = report["timing"]
    assert tm["replies"] > 0 and set(tm["reply_start_minus_rdt_us"]) == {"min", "median", "max"}
    assert tm["source"] in ("bus", "port") and tm["resolution"]
    assert report["result"] in ("PASS", "FAIL", "NOTHING COMPARED", "INTERRUPTED")


@pytest.mark.parametrize("profile", ["ax12", "ax12a"])
def test_every_case_passes_against_the_matching_profile(serve, tmp_path, profile):
    emu = serve(profile=profile)
    proc, report = run_report(tmp_path, emu, "--profile", profile)
    check_schema(report)
    # every reply starts at 2 us x Return Delay Time on the simulated wire: none early, none late
    tm = report["timing"]
    assert tm["source"] == "bus" and tm["early"] == 0 and tm["late"] == 0, tm
    assert tm["replies"] > 200 and -1.0 <= tm["reply_start_minus_rdt_us"]["min"], tm
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert report["totals"]["failed"] == 0
    assert report["restored"] and not report["interrupted"]
    # every group ran, and nothing was skipped for a reason other than the port's limits
    assert all(g["passed"] > 0 for g in report["groups"]) and len(report["groups"]) == len(R.GROUPS)
    assert set(report["skipped_reasons"]) <= {"api", "event", "power-cycle", "servos", "temperature", "lock",
                                              "mapping"}
    assert report["skipped_reasons"].get("mapping", 0) <= 1
    assert "result: PASS" in proc.stdout
    if profile == "ax12":
        # README.md's run is on its link, /tmp/ax12, and a state folder of its own.
        shown = proc.stdout.replace(str(emu.path), "/tmp/ax12").replace(str(emu.control),
                                                                         "/tmp/readme-state/ax12/control.sock")
        doc_samples.check("conform-pass", shown, conform_sample_line)


def conform_sample_line(line):
    """A line of a conform run's output as compared with README.md's: the timing figures masked
    (the count of replies follows the cases run again after a lost answer)."""
    return re.sub(r"[-+]?\d+(\.\d+)?", "N", line) if line.startswith("timing:") else line


def test_without_allow_eeprom_no_eeprom_case_runs_and_the_table_is_left_as_found(serve, tmp_path):
    emu = serve()
    # a device not at the factory's settings: RAM and EEPROM
    for addr, value in ((T.LED, [1]), (T.PUNCH, [40, 0]), (T.ALARM_LED, [5])):
        assert P.parse(talk(emu.path, P.instruction_packet(1, T.INST_WRITE, [addr] + value), 6)).code == 0
    before = read_table(emu.path)
    report_path = tmp_path / "r.json"
    proc = conform("--port", emu.path, "--only", "ranges", "--only", "matrix", "--report", report_path,
                   "--emulator", emu.control)
    report = json.loads(report_path.read_text())
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert ran(report) and all(not c["eeprom"] for c in ran(report))
    reasons = {c["name"]: c["reason"] for c in report["cases"] if c["status"] == "skipped"}
    # a case that writes an EEPROM item with another value, one that needs an EEPROM item at its
    # factory value (Alarm LED is 5 here), one of the matrix's Status Return Level changes
    assert reasons["WRITE of Return Delay Time = 0 (min) is accepted"].startswith("needs --allow-eeprom")
    assert "Alarm LED" in reasons["WRITE of Alarm LED = 0 (min) is accepted"]
    assert reasons["PING to its own ID at Status Return Level 0"].startswith("needs --allow-eeprom")
    after = read_table(emu.path)
    writable = [a for it in T.ITEMS if it.access_ax12 == "RW" for a in range(it.addr, it.addr + it.size)]
    assert [after[a] for a in writable] == [before[a] for a in writable]


# --- the other profile ---------------------------------------------------------------------------

ITEM_BY_ADDR = {item.addr: item for item in T.ITEMS}


def differing_factory_addresses():
    """Addresses whose factory value differs between the profiles (the generated table)."""
    out = set()
    for item in T.ITEMS:
        if item.default_ax12 != item.default_ax12a:
            out |= set(range(item.addr, item.addr + item.size))
    return out


def rounds_bytes(record, ignore):
    """Each round of the record (from a factory-fresh servo) as its steps, exchanges as (sent,
    heard) with READ data at the ignored addresses (and the checksum after them) blanked, and
    so the data of a one-byte WRITE to a read-only ignored address (the test wrote the value it
    found there, changed: Firmware Version) with its checksum."""
    out = []
    for bus, steps in R.split_rounds(record["steps"]):
        key = [json.dumps(bus, sort_keys=True)]
        for s in steps:
            if s["kind"] != "exchange":
                key.append((s["kind"], json.dumps(s.get("baud"))))
                continue
            sent, heard = hexes(s["sent"]), list(hexes(s["heard"]))
            p = P.parse(sent)
            if p and p.code == T.INST_WRITE and len(p.params) == 2 and p.params[0] in ignore and \
                    getattr(ITEM_BY_ADDR.get(p.params[0]), "access_ax12", "") == "R":
                sent = list(sent)
                sent[6] = sent[7] = None
            if p and p.code == T.INST_READ and len(p.params) == 2 and len(heard) == 6 + p.params[1]:
                blank = [i for i in range(p.params[1]) if p.params[0] + i in ignore]
                for i in blank:
                    heard[5 + i] = None
                if blank:
                    heard[-1] = None
            key.append((tuple(sent), tuple(heard)))
        out.append(tuple(key))
    return out


def twin_name(name):
    """Conversations written once per profile pair up by name: broadcast_ping_ax12(a).conv."""
    return re.sub(r"_ax12a?\.conv$", ".conv", name)


def effective_reset(record):
    """A RESET the servo acts on: well-formed, to its ID or broadcast, not refused."""
    buses = [s for s in record["steps"] if s["kind"] == "bus"]
    if not buses:
        return False
    servo = buses[0]["ids"][0]
    for s in record["steps"]:
        if s["kind"] == "exchange":
            p = P.parse(hexes(s["sent"]))
            heard = P.parse(hexes(s["heard"])) if s["heard"] else None
            if p and p.code == T.INST_RESET and p.checksum_ok and not p.params and \
                    p.ident in (servo, T.ID_BROADCAST) and not (heard and heard.code & T.ERR_INSTRUCTION):
                return True
    return False


def expected_profile_differences(compared, device):
    """(paired, expected): the cases of profile `compared` that have a twin of the same name in
    `device`'s records, and those of them a servo of profile `device` must fail: a round (from a
    factory-fresh servo) the twin does not have with the same bytes (but for READ data of items
    whose factory value differs: the tool starts every case from `compared`'s factory values), or
    a RESET (after which the whole table holds the device's factory values)."""
    ignore = differing_factory_addresses()
    theirs = {(r["group"], twin_name(r["name"])): r for r in records(device)}
    paired, expected = set(), set()
    for r in records(compared):
        key = (r["group"], r["name"])
        other = theirs.get((r["group"], twin_name(r["name"])))
        if other is None:
            continue
        paired.add(key)
        if set(rounds_bytes(r, ignore)) - set(rounds_bytes(other, ignore)) or (effective_reset(r) and ignore):
            expected.add(key)
    return paired, expected


@pytest.mark.parametrize("compared,device", [("ax12", "ax12a"), ("ax12a", "ax12")])
def test_the_other_profile_fails_exactly_where_the_profiles_differ(serve, tmp_path, compared, device):
    emu = serve(profile=device)
    proc, report = run_report(tmp_path, emu, "--profile", compared)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    ran_keys = {(c["group"], c["name"]) for c in ran(report)}
    paired, expected = expected_profile_differences(compared, device)
    expected &= ran_keys
    assert expected, "the profiles differ in some case that runs"
    # a case of one profile alone (no twin to derive its outcome from) may pass or fail
    assert failing(report) & paired == expected, proc.stdout
    assert report["restored"]


# --- broken firmware builds ----------------------------------------------------------------------

def srl_silences(record):
    """Exchanges to the servo's own ID (a whole packet) at Status Return Level 0 or 1 that the
    record hears nothing back for: a servo that ignores the level answers them."""
    bus = [s for s in record["steps"] if s["kind"] == "bus"]
    if not bus:
        return False
    ident, level = bus[0]["ids"][0], 2
    for s in record["steps"]:
        if s["kind"] == "bus":
            ident, level = s["ids"][0], 2
        if s["kind"] != "exchange":
            continue
        p = P.parse(hexes(s["sent"]))
        if p and p.ident == ident and level < 2 and not s["heard"]:
            return True
        for text in s.get("changes") or ():
            m = re.match(r"^Status Return Level (\d+) \u2192 (\d+)$", text)
            if m:
                level = int(m.group(2))
            m = re.match(r"^ID (\d+) \u2192 (\d+)$", text)
            if m:
                ident = int(m.group(2))
    return False


def broadcast_reads(record):
    """A READ to the broadcast ID with a good checksum: answered by a servo that answers them."""
    for s in record["steps"]:
        if s["kind"] == "exchange":
            p = P.parse(hexes(s["sent"]))
            if p and p.ident == T.ID_BROADCAST and p.code == T.INST_READ and p.checksum_ok:
                return True
    return False


@pytest.mark.parametrize("defect,touched", [("IGNORE_SRL", srl_silences), ("BROADCAST_READ", broadcast_reads)])
def test_a_broken_build_fails_exactly_the_cases_its_defect_touches(serve, tmp_path, defect, touched):
    elf = DEFECTS / defect / "ax12-ax12-atmega88.elf"
    assert elf.exists(), "build the defect firmware first (cmake --build): %s" % elf
    emu = serve(profile="ax12", extra=["--elf", str(elf)])
    proc, report = run_report(tmp_path, emu, "--profile", "ax12")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    ran_keys = {(c["group"], c["name"]) for c in ran(report)}
    expected = {(r["group"], r["name"]) for r in records("ax12") if touched(r)} & ran_keys
    assert expected
    assert failing(report) == expected, proc.stdout
    assert report["restored"]
    if defect == "IGNORE_SRL":
        doc_samples.check("conform-failures", proc.stdout)


# --- Ctrl-C in an EEPROM case --------------------------------------------------------------------

def talk(path, packet, expect, baud=1000000):
    """One raw exchange on the device at path: up to expect bytes back within 0.3 s."""
    import serial
    with serial.Serial(path, baud) as port:
        return transact(port, packet, expect, timeout_s=0.3)


def read_table(path, ident=1):
    got = talk(path, P.instruction_packet(ident, T.INST_READ, [0, T.TABLE_SIZE]), 6 + T.TABLE_SIZE)
    p = P.parse(got)
    assert p is not None and p.checksum_ok, got.hex()
    return list(p.params)


def test_ctrl_c_in_an_eeprom_case_leaves_the_original_settings(serve, tmp_path):
    emu = serve()
    # settings other than the factory's, among them one the case resets to factory first
    for addr, value in ((T.CW_ANGLE_LIMIT, [1, 0]), (T.RETURN_DELAY_TIME, [100]), (T.ALARM_LED, [5])):
        assert P.parse(talk(emu.path, P.instruction_packet(1, T.INST_WRITE, [addr] + value), 6)).code == 0
    before = read_table(emu.path)
    cmd = [sys.executable, str(TOOL), "--build", str(BUILD), "--port", emu.path, "--allow-eeprom", "-v",
           "--emulator", emu.control, "--case", "A baud change applies after the reply"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen = []
    for line in proc.stderr:
        seen.append(line)
        # step 1 wrote Baud Rate 34: the device listens at 57 600 bit/s now; step 2 waits for silence
        if "step 1: sent FF FF 01 04 03 04 22" in line:
            proc.send_signal(signal.SIGINT)
            break
    out, err = proc.communicate(timeout=60)
    err = "".join(seen) + err
    assert proc.returncode == 130, out + err
    assert "Traceback" not in err
    assert "interrupted" in err and "step 3" not in err, err
    report_line = [ln for ln in out.splitlines() if ln.startswith("settings:")]
    assert report_line and "written back" in report_line[0], out
    emu.restart()  # settings read back after a restart: what the EEPROM holds
    after = read_table(emu.path)
    assert after[:T.EEPROM_SIZE] == before[:T.EEPROM_SIZE]


# --- two devices at one ID, bad input ------------------------------------------------------------

class FakeBus:
    """A pty whose far end answers every PING to ID 1 or broadcast with `reply`."""

    def __init__(self, reply):
        self.master, slave = pty.openpty()
        tty.setraw(slave)
        self.path = os.ttyname(slave)
        self.slave = slave
        self.reply = reply
        self.stop = False
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        buf = bytearray()
        while not self.stop:
            try:
                r, _, _ = select.select([self.master], [], [], 0.05)
                if not r:
                    continue
                buf += os.read(self.master, 256)
            except OSError:
                return
            while True:
                p = P.take(buf)
                if p is None:
                    break
                if p.checksum_ok and p.code == T.INST_PING and p.ident in (1, T.ID_BROADCAST) and self.reply:
                    time.sleep(0.0005)
                    os.write(self.master, self.reply)

    def close(self):
        self.stop = True
        self.thread.join(timeout=2)
        os.close(self.master)
        os.close(self.slave)


@pytest.mark.parametrize("reply", [
    bytes(P.status_packet(1, 0)) * 2,  # two status packets, one after the other
    bytes(b | c for b, c in zip(P.status_packet(1, 0), P.status_packet(1, 0x20))) + b"\xfc",  # on top of each other
], ids=["two-packets", "garbled"])
def test_two_devices_at_the_id_are_refused(reply):
    bus = FakeBus(reply)
    try:
        proc = conform("--port", bus.path, "--only", "matrix", timeout=60)
    finally:
        bus.close()
    assert proc.returncode == 3, proc.stdout + proc.stderr
    assert "refused" in proc.stderr and "more than one device answers at ID 1" in proc.stderr


def test_bad_input_is_a_clear_message(tmp_path):
    proc = conform("--port", tmp_path / "no-such-port")
    assert proc.returncode == 2 and "no such port" in proc.stderr
    bus = FakeBus(b"")  # nothing answers
    try:
        proc = conform("--port", bus.path, timeout=60)
    finally:
        bus.close()
    assert proc.returncode == 2 and "no device answers a PING at ID 1" in proc.stderr
    proc = conform("--port", "/dev/null", "--baud", "300")
    assert proc.returncode == 2 and "--baud" in proc.stderr
