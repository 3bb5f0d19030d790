# SPDX-License-Identifier: GPL-3.0-or-later
"""How often the dashboard may update: as often as a live view needs while the machine has CPU
to spare, less often while it has none, so that watching never slows the bus it watches
(docs/dashboard.md "How often the page updates").

The signal is the machine's idle CPU, in cores, from /proc/stat (Linux): a client that polls its
port without sleeping and the emulator's servos can fill every core, and then each frame the
page draws is time taken from them. Without /proc/stat the rate stays full.
"""
import os

FULL_HZ = 20          # the live view: whole updates a second while a core is free
BUSY_HZ = 2           # while the machine has no core to spare
DOWN_BELOW_CORES = 0.25  # at FULL_HZ: idle below this ...
DOWN_AFTER_S = 2         # ... for this many readings in a row -> BUSY_HZ
UP_AT_CORES = 0.6        # at BUSY_HZ: idle at least this (room for FULL_HZ's own cost) ...
UP_AFTER_S = 3           # ... for this many readings in a row -> FULL_HZ


def cpu_times(stat_text):
    """(busy, idle) jiffies summed over every CPU, from the text of /proc/stat's first line."""
    fields = stat_text.split("\n", 1)[0].split()
    if not fields or fields[0] != "cpu":
        raise ValueError("not /proc/stat: %r" % stat_text[:40])
    values = [int(v) for v in fields[1:]]
    idle = values[3] + (values[4] if len(values) > 4 else 0)  # idle + iowait
    busy = sum(values[:8]) - idle                            # guest time is inside user already
    return busy, idle


class IdleCores:
    """Idle CPU, in cores, between two readings of /proc/stat (`read` returns its text)."""

    def __init__(self, read=None):
        # AX12_PROC_STAT: a file read instead of /proc/stat, for a test that must give the
        # machine a known load whatever else runs beside it.
        path = os.environ.get("AX12_PROC_STAT") or "/proc/stat"
        self.read = read or (lambda: open(path).read())
        self.last = None

    def reading(self):
        """The idle cores since the last call; None for the first call, or without /proc/stat."""
        try:
            text = self.read()
            cores = sum(1 for line in text.splitlines() if line[:3] == "cpu" and line[3:4].isdigit())
            now = cpu_times(text)
        except (OSError, ValueError, IndexError):
            return None
        last, self.last = self.last, now
        if last is None:
            return None
        busy, idle = now[0] - last[0], now[1] - last[1]
        if busy + idle <= 0:
            return None
        return max(cores, 1) * idle / (busy + idle)


class UpdateRate:
    """The dashboard's update rate from one idle reading a second (IdleCores): it starts at
    BUSY_HZ (a page opened on a busy machine never costs it FULL_HZ), goes to FULL_HZ after
    UP_AFTER_S readings in a row with UP_AT_CORES idle, back to BUSY_HZ after DOWN_AFTER_S
    readings in a row below DOWN_BELOW_CORES. None (no reading) counts as idle."""

    def __init__(self):
        self.hz = BUSY_HZ
        self.run = 0  # readings in a row that argue for the other rate

    def update(self, idle_cores):
        """Takes one reading; returns the rate (Hz) from now on."""
        if self.hz == BUSY_HZ:
            wants_other, needed = idle_cores is None or idle_cores >= UP_AT_CORES, UP_AFTER_S
        else:
            wants_other, needed = idle_cores is not None and idle_cores < DOWN_BELOW_CORES, DOWN_AFTER_S
        self.run = self.run + 1 if wants_other else 0
        if self.run >= needed:
            self.hz = FULL_HZ if self.hz == BUSY_HZ else BUSY_HZ
            self.run = 0
        return self.hz
