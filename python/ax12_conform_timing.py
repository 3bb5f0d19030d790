# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 conform`: reply timing and its verdict (docs/conform.md "Timing").

Every reply's delay is measured twice when it can be: on the wall clock at the port (the first
byte's arrival less its own time, from the request's end as written), and, when the device runs
on the emulator's bus, exactly on the simulated wire (python/ax12_conform_bus_clock.py). A
reply is flagged, as a difference of its case, only where the measurement can tell:

- the bus (exact to a cycle): early when it starts more than EXACT_EARLY_US before 2 us x
  Return Delay Time, late when more than LATE_US after it;
- a serial port of the host's own (native, USB): early when the wall clock says it started more
  than PORT_EARLY_US before; a byte cannot arrive before it was sent, so the port's latencies
  only ever make a reply look later;
- a pty with no bus clock: never. The emulator behind it paces simulated time to the wall
  clock and catches up after falling behind, so a reply can look early or late by
  milliseconds; the summary gives the numbers and says so.
"""
import statistics

# A reply starting this much before the Return Delay Time has passed is early, on the bus: a few
# cycles of the simulated AVR are the servo's own jitter; a device that ignores Return Delay
# Time is early by 2 us x RDT, hundreds of us at the factory's 250.
EXACT_EARLY_US = 1.0
# On the bus, a reply starting this much after 2 us x Return Delay Time is late: it leaves room
# for a servo's work on a packet before its reply (this project's firmware starts the replies
# it prepares in its main loop 93-131 us after the request below a Return Delay Time of 65:
# docs/firmware.md "Reply timing").
LATE_US = 150.0
# On a serial port, on the wall clock: a reply this much earlier than the Return Delay Time.
PORT_EARLY_US = 100.0


def port_resolution(kind):
    """What the wall clock at a port of this kind can tell, in words."""
    if kind == "pty":
        return ("a pty: the arrival times carry the emulator's pacing (simulated time catching up "
                "with the wall clock) and the host's scheduling, milliseconds either way: no verdict on "
                "Return Delay Time; run against `scripts/ax12 serve` with --emulator (its control "
                "socket) for exact timing")
    if kind and kind.startswith("usb-serial"):
        return ("a USB adapter: bytes reach the host when the latency timer expires or its buffer fills, so "
                "reply starts are only known to about the latency timer; replies more than %d us early "
                "are flagged (a port only ever delays a byte)" % PORT_EARLY_US)
    return ("a serial port: the arrival times carry the driver's and the host's scheduling, typically tens "
            "to hundreds of us; replies more than %d us early are flagged (a port only ever delays a byte)"
            % PORT_EARLY_US)


class Timer:
    """The reply timings of a run. add() takes one reply as the port saw it; with a bus clock
    its exact delay is looked up once the emulator has reported the packets (settle())."""

    def __init__(self, port, clock=None):
        self.port = port
        self.clock = clock
        self.pending = []  # (case, entry, sent_end)

    @property
    def source(self):
        return "bus" if self.clock else "port"

    def add(self, case, label, heard, rdt_us, late):
        """One reply of case: heard (ax12_conform_device.Heard) with its first byte; rdt_us the
        Return Delay Time in force; late: it came after --timeout."""
        start_us = (heard.first_arrival - self.port.byte_s() - heard.request_end) * 1e6
        entry = {"step": label, "start_us": round(start_us), "return_delay_us": rdt_us, "late": late}
        case.timings.append(entry)
        if self.clock:
            entry["bus_start_us"] = None
            self.pending.append((case, entry, heard.sent_end))
        elif self.port.kind() != "pty" and start_us - rdt_us < -PORT_EARLY_US:
            self._flag(case, entry, "early", start_us, "on the wall clock")

    def forget(self, case):
        """Drops the replies of case not looked up yet (it is run again)."""
        self.pending = [p for p in self.pending if p[0] is not case]

    def settle(self, final=False):
        """Looks the pending replies up on the bus (final: waits for the last ones)."""
        if not self.clock:
            return
        self.clock.poll()
        left = []
        for case, entry, sent_end in self.pending:
            found = self.clock.delay(self.port.sent, sent_end, final)
            if found is None:
                if not final:
                    left.append((case, entry, sent_end))
                continue
            _, delay = found
            if delay is None:
                continue
            entry["bus_start_us"] = round(delay, 2)
            err = delay - entry["return_delay_us"]
            if err < -EXACT_EARLY_US:
                self._flag(case, entry, "early", delay, "on the bus")
            elif err > LATE_US:
                self._flag(case, entry, "late", delay, "on the bus")
        self.pending = left

    @staticmethod
    def _flag(case, entry, how, start_us, where):
        entry["flag"] = how
        rdt = entry["return_delay_us"]
        note = ("the reply started %.1f us after the request's end (%s); Return Delay Time %d asks for %d us: "
                "%.1f us %s" % (start_us, where, rdt // 2, rdt, abs(start_us - rdt), how))
        case.differ(entry["step"], note, timing={"start_us": round(start_us, 2), "return_delay_us": rdt,
                                                 "flag": how})
        if case.status == "passed":
            case.status = "failed"


def summary(cases, source, port_kind, clock):
    """The timing part of the report: the delays less the Return Delay Time, by the best clock
    the run had."""
    key = "bus_start_us" if source == "bus" else "start_us"
    entries = [e for c in cases for e in c.timings if e.get(key) is not None]
    if not entries:
        return None
    errs = [e[key] - e["return_delay_us"] for e in entries]
    out = {"source": source,
           "resolution": ("exact: simulated time, %.4f us" % clock.resolution_us if source == "bus"
                          else port_resolution(port_kind)),
           "replies": len(entries),
           "reply_start_minus_rdt_us": {"min": round(min(errs), 1), "median": round(statistics.median(errs), 1),
                                        "max": round(max(errs), 1)},
           "early": sum(1 for e in entries if e.get("flag") == "early"),
           "late": sum(1 for e in entries if e.get("flag") == "late"),
           "after_timeout": sum(1 for c in cases for e in c.timings if e["late"])}
    if source == "bus" and clock.dropped:
        out["bus_packets_dropped"] = clock.dropped
    return out
