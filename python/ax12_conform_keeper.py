# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 conform`: keeping the device as it was found (docs/conform.md "A real device
stays as it was found"): where it is now (ID and baud, as the cases move it), looking for it
when it does not answer, and writing its settings back.
"""
import time

import ax12_table as T
from ax12_conform_cases import access
from ax12_conform_device import Problem, bps_of

# Baud Rate registers of the usual bauds (1 Mbps, 500k, 400k, 250k, 200k, 115200, 57600, 19200,
# 9600): where a device that cannot be found is looked for last.
COMMON_BAUDS = (1, 3, 4, 7, 9, 16, 34, 103, 207)
# While a device is looked for, the place it should be is tried again after this many others.
RECHECK_EVERY = 8


class Keeper:
    def __init__(self, port, dev, args, original, warnings):
        self.port = port
        self.dev = dev
        self.args = args
        self.profile = args.profile
        self.original = original  # the table as found
        self.where = (args.id, original[T.BAUD_RATE])  # (id, register) the device is expected at now
        self.written = set()  # (id, register) it may have been moved to
        self.case_ids, self.case_bauds = set(), set()  # where the case running may move the device
        self.restore_problems = []
        self.warnings = warnings  # the run's, shared
        self.table = list(original)  # the device's table as last read
        self.touched_eeprom = False  # the round running wrote the EEPROM area

    def places(self):
        """Where to look, most likely first: where it should be, where it was found, the factory
        ID and baud, where the cases moved it, then every ID the case used at every baud."""
        orig = (self.args.id, self.original[T.BAUD_RATE])
        cands = [self.where, orig, (1, 1), (self.where[0], orig[1]), (orig[0], self.where[1]), (1, orig[1])]
        cands += sorted(self.written)
        ids = {c[0] for c in cands} | self.case_ids
        bauds = {c[1] for c in cands} | self.case_bauds | set(COMMON_BAUDS)
        cands += [(i, b) for b in sorted(bauds) for i in sorted(ids)]
        return list(dict.fromkeys(cands))

    def _answers_at(self, ident, reg):
        try:
            self.port.set_register(reg)
        except Problem:
            return False
        self.port.drain()
        return self.dev.answers_ping(ident)

    def locate(self, seconds=0.0, passes=3):
        """(id, register) where the device answers a PING now, or None. Looks through places()
        at least `passes` times, and on until `seconds` have passed, trying where it should
        be again every RECHECK_EVERY places (a device that comes back is found soon)."""
        deadline = time.monotonic() + seconds
        done = 0
        while True:
            cands = self.places()
            first = cands[0]
            for k, (ident, reg) in enumerate(cands):
                if self._answers_at(ident, reg):
                    return ident, reg
                if k and k % RECHECK_EVERY == 0 and self._answers_at(*first):
                    return first
            done += 1
            if done >= passes and time.monotonic() >= deadline:
                return None
            time.sleep(0.1)

    def restore(self, final):
        """Writes back every setting of the original table that differs (EEPROM; RAM too when
        final), the ID and the baud last, and checks by reading it back."""
        orig = self.original
        loc = self.locate()
        if loc is None:
            self.restore_problems.append("the device does not answer at ID %d or any ID and baud the run used; "
                                         "it may be at an ID or baud the tool did not try" % self.args.id)
            return False
        ident, reg = loc
        table = self.dev.read(0, T.TABLE_SIZE, ident=ident)
        if table is None:  # Status Return Level 0: answers PING only
            self.dev.write(T.STATUS_RETURN_LEVEL, [max(orig[T.STATUS_RETURN_LEVEL], 1)], ident=ident, answered=False)
            table = self.dev.read(0, T.TABLE_SIZE, ident=ident)
        if table is None:
            self.restore_problems.append("the device answers PING at ID %d but not READ" % ident)
            return False
        items = [it for it in T.ITEMS if it.addr < T.EEPROM_SIZE and access(it, self.profile) == "RW"
                 and it.addr not in (T.ID, T.BAUD_RATE)]
        if final:
            items += [it for it in T.ITEMS if it.addr >= T.EEPROM_SIZE and access(it, self.profile) == "RW"
                      and it.addr not in (T.LOCK, T.REGISTERED_INSTRUCTION)]
        # Status Return Level first when it silences replies, then the rest
        items.sort(key=lambda it: it.addr != T.STATUS_RETURN_LEVEL or table[T.STATUS_RETURN_LEVEL] >= 2)
        level = table[T.STATUS_RETURN_LEVEL]
        for it in items:
            want = orig[it.addr:it.addr + it.size]
            if table[it.addr:it.addr + it.size] != want:
                self.dev.write(it.addr, want, ident=ident, answered=level >= 2)
                if it.addr == T.STATUS_RETURN_LEVEL:
                    level = want[0]
        if table[T.ID] != orig[T.ID] or ident != orig[T.ID]:
            self.dev.write(T.ID, [orig[T.ID]], ident=ident, answered=level >= 2)
            ident = orig[T.ID]
        if table[T.BAUD_RATE] != orig[T.BAUD_RATE]:
            self.dev.write(T.BAUD_RATE, [orig[T.BAUD_RATE]], ident=ident, answered=level >= 2)
            time.sleep(0.01)
        self.port.set_register(orig[T.BAUD_RATE])
        self.port.drain()
        self.where = (orig[T.ID], orig[T.BAUD_RATE])
        back = self.dev.read(0, T.TABLE_SIZE, ident=orig[T.ID])
        if back is None:
            self.restore_problems.append("after restoring, ID %d does not answer a READ at %d bit/s"
                                         % (orig[T.ID], bps_of(orig[T.BAUD_RATE])))
            return False
        self.table = list(back)
        wrong = [it.title for it in items if back[it.addr:it.addr + it.size] != orig[it.addr:it.addr + it.size]]
        if wrong:
            self.restore_problems.append("could not restore %s" % ", ".join(wrong))
            return False
        if final and back[T.REGISTERED_INSTRUCTION] and not orig[T.REGISTERED_INSTRUCTION]:
            self.warnings.append("a registered write is left in the device (RAM; gone at the next power-up)")
        return True
