# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 conform`: the report (docs/conform.md "Reading the output"): the summary on
stdout, FILE.md and FILE.json. Every format carries every difference of every case.

The result: PASS (every case compared passed), FAIL (a case failed, the device would not take
a starting state, or it was lost), NOTHING COMPARED (every case was skipped: the summary names
the flag that would run them), INTERRUPTED.
"""
import json
import sys

import ax12_conformance_records as R
import ax12_table as T
from ax12_conform_cases import describe_field
from ax12_conform_device import bps_of
from ax12_conform_timing import EXACT_EARLY_US, LATE_US, PORT_EARLY_US
from ax12_conform_timing import summary as timing_summary

SKIP_WORDS = {"eeprom": "write the EEPROM area: run with --allow-eeprom",
              "power-cycle": "power-cycle the servo (not over a port)",
              "servos": "need more than one servo on the bus",
              "event": "set a condition inside the servo (not over a port)",
              "api": "call the core's API directly (no bus)",
              "lock": "set Lock (only a power cycle clears it)",
              "temperature": "need the servo at another temperature",
              "mapping": "cannot be mapped to this device's ID and baud (see the JSON report)",
              "conflict": "need an item the device will not take at the factory's value (starting-state conflicts)"}
# What would run a case skipped for this reason.
SKIP_FLAGS = {"eeprom": "--allow-eeprom"}


def verdict(s):
    t = s["totals"]
    if s["interrupted"]:
        return "INTERRUPTED"
    if s["stopped"] or t["failed"] or s["conflicts"]:
        return "FAIL"
    if t["passed"] == 0:
        return "NOTHING COMPARED"
    return "PASS"


def summarise(conform, interrupted):
    a = conform.args
    groups = []
    for g in R.GROUPS:
        cs = [c for c in conform.cases if c.group == g]
        if not cs:
            continue
        groups.append({"group": g, "passed": sum(c.status == "passed" for c in cs),
                       "failed": sum(c.status == "failed" for c in cs),
                       "skipped": sum(c.status == "skipped" for c in cs),
                       "not_run": sum(c.status in (None, "not run") for c in cs)})
    skipped = {}
    for c in conform.cases:
        if c.status == "skipped":
            skipped[c.skip_kind] = skipped.get(c.skip_kind, 0) + 1
    orig = conform.original
    source = conform.timer.source if conform.timer else "port"
    port_kind = conform.port.kind() if conform.port else None
    s = {
        "tool": "scripts/ax12 conform",
        "port": a.port, "port_kind": port_kind,
        "id": a.id, "baud_register": orig[T.BAUD_RATE] if orig else a.baud_register,
        "profile": a.profile, "allow_eeprom": a.allow_eeprom,
        "emulator": conform.timer.clock.path if conform.timer and conform.timer.clock else None,
        "device": {"model": (orig[0] | orig[1] << 8) if orig else None,
                   "firmware": orig[2] if orig else None,
                   "return_delay_time": orig[T.RETURN_DELAY_TIME] if orig else None},
        "groups": groups,
        "totals": {k: sum(g[k] for g in groups) for k in ("passed", "failed", "skipped", "not_run")},
        "skipped_reasons": dict(sorted(skipped.items())),
        "conflicts": list(conform.conflicts.values()),
        "silences": conform.silences,
        "stopped": conform.stopped,
        "timing": timing_summary(conform.cases, source, port_kind, conform.timer.clock if conform.timer else None),
        "restored": not conform.restore_problems,
        "restore_problems": conform.restore_problems,
        "warnings": conform.warnings,
        "interrupted": interrupted,
        "cases": [{"group": c.group, "name": c.name, "status": c.status or "not run",
                   "eeprom": c.eeprom, "skip": c.skip_kind, "reason": c.reason, "differences": c.differences,
                   "notes": c.notes, "seconds": round(c.seconds, 3), "replies": c.timings}
                  for c in conform.cases],
    }
    s["result"] = verdict(s)
    return s


def difference_lines(d):
    """A difference as lines: the bytes (sent, expected, heard) first when it has them, then
    every differing byte named, or the note."""
    if "heard" in d:
        lines = ["%s: sent %s, expected %s, heard %s" % (d["step"], d["sent"], d["expected"] or "silence",
                                                          d["heard"] or "silence")]
        lines += ["    " + describe_field(f) for f in d.get("bytes") or ()]
        return lines
    return ["%s: %s" % (d["step"], d["note"])]


def nothing_compared_text(s):
    flags = {}
    for kind, n in s["skipped_reasons"].items():
        if kind in SKIP_FLAGS:
            flags[SKIP_FLAGS[kind]] = flags.get(SKIP_FLAGS[kind], 0) + n
    if flags:
        return "; ".join("%s would run %d of them" % (flag, n) for flag, n in flags.items())
    return "no option runs them over this port (see the reasons above)"


def text_summary(s):
    lines = []
    dev = s["device"]
    lines.append("ax12 conform: %s (%s), ID %d at %d bit/s, compared with profile %s"
                 % (s["port"], s["port_kind"], s["id"], bps_of(s["baud_register"]), s["profile"]))
    if dev["model"] is not None:
        lines.append("device: model number %d, firmware %d, Return Delay Time %d (%d us)"
                     % (dev["model"], dev["firmware"], dev["return_delay_time"], dev["return_delay_time"] * 2))
    if s["emulator"]:
        lines.append("timing: from the emulator's bus (control socket %s)" % s["emulator"])
    lines.append("")
    lines.append("%-14s %7s %7s %8s" % ("group", "passed", "failed", "skipped"))
    for g in s["groups"]:
        lines.append("%-14s %7d %7d %8d%s" % (g["group"], g["passed"], g["failed"], g["skipped"],
                                             "  (%d not run)" % g["not_run"] if g["not_run"] else ""))
    t = s["totals"]
    lines.append("%-14s %7d %7d %8d" % ("total", t["passed"], t["failed"], t["skipped"]))
    if s["skipped_reasons"]:
        lines.append("skipped:")
        for k, n in sorted(s["skipped_reasons"].items(), key=lambda kv: (-kv[1], kv[0])):
            lines.append("  %3d %s" % (n, SKIP_WORDS.get(k, k)))
    if s["conflicts"]:
        lines.append("")
        lines.append("starting-state conflicts (the device will not take the factory's value; the cases that "
                     "read or write the item are not compared, the others run):")
        for c in s["conflicts"]:
            lines.append("- %s (address %d) = %d: %s; %d case%s not compared"
                         % (c["item"], c["address"], c["value"], c["problem"], len(c["cases"]),
                            "" if len(c["cases"]) == 1 else "s"))
    if s["silences"]:
        lines.append("")
        lines.append("silences (a reply due, and no answer to a PING either):")
        for e in s["silences"]:
            where = ("found again at ID %d, %d bit/s" % (e["found"]["id"], e["found"]["bps"]) if e["found"]
                     else "not found again")
            lines.append("- during '%s', %s: silent for %.1f s, %s; not run: %s"
                         % (e["case"], e["step"], e["seconds"], where, e["cost"]))
    if s["stopped"]:
        lines.append("stopped: %s" % s["stopped"])
    failed = [c for c in s["cases"] if c["status"] == "failed"]
    if failed:
        lines.append("")
        lines.append("failures (every difference):")
        for c in failed:
            lines.append("- %s / %s" % (c["group"], c["name"]))
            for d in c["differences"]:
                lines += ["    " + ln for ln in difference_lines(d)]
    tm = s["timing"]
    if tm:
        r = tm["reply_start_minus_rdt_us"]
        lines.append("")
        if tm["source"] == "bus":
            lines.append("timing: %d replies started %+.1f..%+.1f us (median %+.1f) after the request's end plus "
                         "2 us x Return Delay Time, on the emulator's bus (exact); %d early (by over %g us), "
                         "%d late (by over %g us)" % (tm["replies"], r["min"], r["max"], r["median"], tm["early"],
                                                      EXACT_EARLY_US, tm["late"], LATE_US))
        else:
            lines.append("timing: %d replies started %+d..%+d us (median %+d) from the request's end plus the Return "
                         "Delay Time, on the wall clock; %d early (by over %d us), %d after --timeout"
                         % (tm["replies"], r["min"], r["max"], r["median"], tm["early"], PORT_EARLY_US,
                            tm["after_timeout"]))
            lines.append("        (%s)" % tm["resolution"])
    for w in s["warnings"]:
        lines.append("warning: " + w)
    if s["restore_problems"]:
        lines.append("")
        for p in s["restore_problems"]:
            lines.append("NOT RESTORED: " + p)
    else:
        lines.append("settings: every setting the run changed was written back and read back")
    if s["interrupted"]:
        lines.append("interrupted: the cases not run are counted as not run")
    result = s["result"]
    if result == "NOTHING COMPARED":
        result += ": every case was skipped; %s" % nothing_compared_text(s)
    lines.append("result: %s" % result)
    return "\n".join(lines)


def markdown_report(s):
    lines = ["# AX-12 conformance of the device on %s" % s["port"], "", "```", text_summary(s), "```", ""]
    lines += ["| group | case | result | differences or reason |", "|---|---|---|---|"]
    for c in s["cases"]:
        if c["status"] == "failed":
            detail = "<br>".join(" ".join(difference_lines(d)) for d in c["differences"])
        else:
            detail = c["reason"] or ""
        lines.append("| %s | %s | %s | %s |" % (c["group"], c["name"], c["status"], detail.replace("|", "\\|")))
    return "\n".join(lines) + "\n"


def write_reports(s, paths):
    for path in paths:
        try:
            with open(path, "w", encoding="utf-8") as f:
                if path.endswith(".json"):
                    json.dump(s, f, indent=1, ensure_ascii=False)
                    f.write("\n")
                else:
                    f.write(markdown_report(s))
        except OSError as e:
            print("ax12 conform: cannot write %s: %s" % (path, e), file=sys.stderr)
