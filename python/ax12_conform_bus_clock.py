# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 conform`: exact reply timing from the emulator's bus (docs/conform.md "Timing").

When the device is a firmware served by `scripts/ax12 serve` (the project's, or a program of
one's own given with --elf), the tool subscribes to the bus monitor's packets on serve's control
socket (docs/dashboard.md "The control socket"): every packet on the simulated wire with the
start bit of its first byte and the end of its last stop bit in simulated microseconds, as
`--log-bus` records them. The tool's own bytes are found in the client's packets by content
(everything the port wrote, in order), so each request's end and the start of the first
servo packet after it are known to the simulator's clock (1/16 us at 16 MHz): the reply's
delay is compared with 2 us x Return Delay Time exactly, whatever the pty and the host's
scheduling did to the bytes on their way.
"""
import bisect
import os
import time

from ax12_control import Control, ControlError, default_socket_path

CLIENT = "client"
OTHER_MASTERS = ("control",)  # the control socket's own packets (docs/dashboard.md)
# Records the emulator had not sent yet are waited for this long at the end of a run.
SETTLE_S = 1.0


class BusClockError(Exception):
    pass


def _hex_bytes(text):
    return bytes(int(h, 16) for h in text.split()) if text else b""


class BusClock:
    """Reply timings of one run, from the bus of the emulator behind the port."""

    source = "bus"
    resolution_us = 1.0 / 16  # one cycle of the simulated 16 MHz AVR

    def __init__(self, control_path, port_path, require_device=False):
        try:
            self.control = Control(control_path, timeout_s=5.0)
            status = self.control.request("status")
        except (ControlError, OSError, ValueError) as e:
            raise BusClockError(str(e))
        device = status.get("device")
        if (device is not None or require_device) and device != os.path.realpath(port_path):
            self.control.close()
            raise BusClockError("the emulator at %s serves %s, not %s" % (control_path, device, port_path))
        try:
            self.control.request("subscribe", telemetry_hz=0, packets=True)
        except (ControlError, OSError, ValueError) as e:
            self.control.close()
            raise BusClockError(str(e))
        self.path = control_path
        self.client = bytearray()  # the client's bytes on the bus, in order
        self.client_record_end = {}  # index of a client record's last byte -> its end (us)
        self.client_record_start = {}  # index of a client record's first byte -> its start (us)
        self.servo_starts = []  # the start (us) of every packet the servos sent, sorted
        self.dropped = 0
        self.shift = None  # where the tool's first byte is in self.client

    def close(self):
        self.control.close()

    def poll(self, wait_s=0.0):
        """Takes in every batch of packets the emulator has pushed (waiting up to wait_s for the
        first)."""
        while True:
            try:
                event = self.control.next_event(wait_s)
            except (ControlError, OSError, ValueError) as e:
                raise BusClockError("the emulator's control socket failed: %s" % e)
            if event is None:
                return
            wait_s = 0.0
            if event.get("event") != "packets":
                continue
            self.dropped = event.get("dropped", self.dropped)
            for p in event["packets"]:
                raw = _hex_bytes(p.get("raw", ""))
                if p["sender"] == CLIENT:
                    if raw:
                        self.client_record_start[len(self.client)] = p["time_us"]
                        self.client += raw
                        self.client_record_end[len(self.client) - 1] = p["end_us"]
                elif p["sender"] not in OTHER_MASTERS:
                    bisect.insort(self.servo_starts, p["time_us"])

    def _align(self, sent):
        if self.shift is None and sent:
            head = bytes(sent[:64])
            if len(self.client) >= len(head):
                at = self.client.find(head)
                self.shift = at if at >= 0 else -1
        return self.shift is not None and self.shift >= 0

    def delay(self, sent, sent_end, final=False):
        """(request end us, delay us or None for no servo packet after it), None when the bus
        does not tell (yet: final waits for what is still on its way). sent: every byte the
        port wrote; sent_end: the request's end in it (Heard.sent_end)."""
        if final:
            deadline = time.monotonic() + SETTLE_S
            while (self.shift is None or len(self.client) < self.shift + len(sent)) and time.monotonic() < deadline:
                self.poll(0.05)
                self._align(sent)
        if not self._align(sent):
            return None
        last = self.shift + sent_end - 1
        if last >= len(self.client):
            return None
        end = self.client_record_end.get(last)
        if end is None:
            return None  # the request's last byte is inside a record: no end of its own
        following = self.client_record_start.get(last + 1)
        if following is None and not final and last + 1 >= len(self.client):
            return None  # the next request is not on the bus yet: a reply may still come in between
        k = bisect.bisect_left(self.servo_starts, end)
        if k < len(self.servo_starts) and (following is None or self.servo_starts[k] < following):
            return end, self.servo_starts[k] - end
        return end, None


    def request_end(self, sent, sent_end):
        """The end (us) of the request that ends at sent_end in sent, once the bus has reported
        it; else None."""
        self.poll()
        if not self._align(sent):
            return None
        return self.client_record_end.get(self.shift + sent_end - 1)

    def now_us(self):
        """The simulation's time now."""
        try:
            return self.control.request("status")["time_us"]
        except (ControlError, OSError, ValueError, KeyError) as e:
            raise BusClockError("the emulator's control socket failed: %s" % e)

    def passed(self, sent, sent_end, window_us):
        """Whether the simulation has run window_us past the end of the request that ends at
        sent_end: a reply due in that window would be on its way to the port."""
        end = self.request_end(sent, sent_end)
        return end is not None and self.now_us() >= end + window_us


def find(port_path, control_path=None):
    """The BusClock of the emulator serving port_path: through control_path when given (a
    BusClockError when it cannot be used), else through the default state directory's socket when
    that emulator serves this port; None when there is none."""
    if control_path:
        return BusClock(control_path, port_path)
    default = default_socket_path()
    if not os.path.exists(default):
        return None
    try:
        clock = BusClock(default, port_path, require_device=True)
    except BusClockError:
        return None
    return clock
