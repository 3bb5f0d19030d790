# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 conform`: the case runner (docs/conform.md).

Conform.run() checks the device (start), then runs every case round by round: the starting
state (prepare), the record's steps with their packets rewritten for the device (run_round),
the table read back (check_after), the settings written back after a case that touched the
EEPROM area (ax12_conform_keeper.py). What it finds beyond the cases' own differences:

- starting-state conflicts: an item the device will not take at the factory's value, found
  once, named once; a case that reads or writes it is not compared, the others run;
- silences: a reply that is due does not come and the device does not answer a PING either:
  it is looked for (--silence-wait) and the run goes on without the rest of that case, or
  stops with the reason;
- leaks: an item a case changed that its record leaves alone, named by address, and named
  again (with the case that left it) where a later case reads it.
"""
import sys
import time

import serial  # pyserial

import ax12_conformance_records as R
import ax12_packets as P
import ax12_table as T
from ax12_conform_bus_clock import BusClockError
from ax12_conform_bus_clock import find as find_bus_clock
from ax12_conform_cases import (DEVICE_OWN, ITEM_AT, LOCK_VALUE, MEASURED_CONDITIONS, PRESENT, Case, access,
                                address_name, apply_changes, changed_addrs, classify, describe_field, error_words,
                                factory_table, item_value, starting_items)
from ax12_conform_device import EEPROM_BYTE_S, GRACE_S, LONGEST_RDT_S, Device, Port, Problem, bps_of, hexs
from ax12_conform_keeper import Keeper
from ax12_conform_rewrite import ids_in, read_window, remap, writes_of
from ax12_conform_timing import Timer


class Refused(Exception):
    pass


class Interrupted(Exception):
    pass


class CaseAbandoned(Exception):
    """The device went silent or moved during a case and was found again: the rest of the case is
    not run."""


class DeviceLost(Exception):
    """The device went silent and was not found again: the run stops."""


class Conform:
    def __init__(self, args):
        self.args = args
        self.profile = args.profile
        self.port = None
        self.dev = None
        self.keeper = None
        self.timer = None
        self.original = None
        self.free_ids = []
        self.others = []
        self.warnings = []
        self.cases = []
        self.records = []
        self.conflicts = {}  # address -> {address, item, value, problem, cases}
        self.silences = []  # {case, step, seconds, found, cost}
        self.left_by = {}  # address -> the case after which it held a value its record does not explain
        self.stopped = None  # why the run stopped before its end

    def say(self, text):
        print(text, file=sys.stderr, flush=True)

    def verbose(self, text):
        if self.args.verbose:
            self.say(text)

    @property
    def restore_problems(self):
        return self.keeper.restore_problems if self.keeper else []

    @property
    def table(self):
        return self.keeper.table

    # -- finding and checking the device --

    def start(self):
        a = self.args
        self.port = Port(a.port, a.baud_register)
        self.dev = Device(self.port, a.id, a.timeout)
        self.port.drain()
        try:
            clock = find_bus_clock(a.port, a.emulator)
        except BusClockError as e:
            raise Problem("--emulator %s: %s" % (a.emulator, e))
        self.timer = Timer(self.port, clock)
        self.port.clock = clock
        first = self.dev.ping(grace=GRACE_S)  # the first contact: a slow host may answer late
        if first is None:
            raise Problem("no device answers a PING at ID %d at %d bit/s on %s (wrong ID, baud or port? "
                          "check --id and --baud)" % (a.id, bps_of(a.baud_register), a.port))
        self.check_single(first)
        table = self.dev.read(0, T.TABLE_SIZE)
        if table is None:
            raise Problem("ID %d answers PING but not a READ of the control table (Status Return Level 0, "
                          "or not an AX-12-like table); the tool needs READ" % a.id)
        self.original = list(table)
        self.keeper = Keeper(self.port, self.dev, a, self.original, self.warnings)
        if table[T.ID] != a.id:
            raise Problem("the device at ID %d reads ID %d at address 3" % (a.id, table[T.ID]))
        if table[T.BAUD_RATE] != a.baud_register:
            # the port's baud is what works; take the register the device reports as its own
            self.warnings.append("the device reads Baud Rate %d; --baud gave %d" % (table[T.BAUD_RATE], a.baud_register))
        if table[T.LOCK] == LOCK_VALUE:
            raise Refused("the device is locked (Lock = 1): only a power cycle clears it, and locked it refuses "
                          "most of the suite; power it off and on and run again")
        if first.code != 0:
            self.warnings.append("the device's PING reply has error byte %02X before any case: a condition "
                                 "holds, and every reply will carry it" % first.code)
        self.find_free_ids()

    def check_single(self, first):
        """Refuses when two devices answer at the ID: a unicast PING must bring one clean status
        packet, a broadcast PING no two packets of one ID and nothing garbled."""
        a = self.args
        two = ("more than one device answers at ID %d: a PING brought %%s (a collision or two status packets); "
               "give every device its own ID and run again" % a.id)
        for _ in range(2):
            got = self.port.exchange(P.instruction_packet(a.id, T.INST_PING, []), 0, a.timeout).data
            packets = P.split(got)
            if got and (packets is None or len(packets) != 1 or not P.parse(packets[0]).checksum_ok
                        or P.parse(packets[0]).ident != a.id):
                raise Refused(two % hexs(got))
        if isinstance(first, (bytes, bytearray)):
            raise Refused(two % hexs(first))
        got = self.port.exchange(P.instruction_packet(T.ID_BROADCAST, T.INST_PING, []), 0, a.timeout * 3).data
        packets = P.split(got) if got else []
        if packets is None or any(not P.parse(p).checksum_ok for p in packets):
            raise Refused("a broadcast PING brought garbled bytes (%s): two devices answered at once; "
                          "give every device its own ID and run again" % hexs(got))
        ids = [P.parse(p).ident for p in packets]
        if ids.count(a.id) > 1:
            raise Refused("a broadcast PING brought %d replies from ID %d: two devices share the ID; "
                          "give every device its own ID and run again" % (ids.count(a.id), a.id))
        self.others = sorted(set(ids) - {a.id})
        if self.others:
            self.warnings.append("other devices answer on this bus: IDs %s" % ", ".join(map(str, self.others)))

    def find_free_ids(self):
        """IDs the records use as 'another ID' (and a few spares), each checked to be silent."""
        wanted = []
        for r in self.records:
            for s in r["steps"]:
                if s["kind"] == "exchange":
                    wanted += sorted(ids_in(R.parse_hex(s["sent"])))
                if s["kind"] == "bus":
                    wanted += s["ids"]
        candidates = []
        for i in list(dict.fromkeys(wanted)) + [200, 201, 202, 203]:
            if i not in candidates and i != T.ID_BROADCAST and i != self.args.id and 0 <= i <= T.ID_MAX:
                candidates.append(i)
        for i in candidates:
            if i not in self.others and self.dev.ping(i) is None:
                self.free_ids.append(i)

    # -- the run --

    def run(self, records):
        self.records = records
        self.cases = [Case(r) for r in records]
        self.start()
        for case in self.cases:
            why = classify(case, self.profile)
            if why:
                case.skip(*why)
        todo = [(n, c) for n, c in enumerate(self.cases, 1) if c.status != "skipped"]
        for k, (n, case) in enumerate(todo):
            self.verbose("[%d/%d] %s: %s" % (n, len(self.cases), case.group, case.name))
            started = time.monotonic()
            try:
                self.run_case(case)
            except DeviceLost as e:
                self.stopped = str(e)
                for _, later in todo[k + 1:]:
                    later.status, later.reason = "not run", "the run stopped: %s" % e
                break
            finally:
                case.seconds = time.monotonic() - started
            self.timer.settle()
            if case.status == "failed" and case.differences:
                self.verbose("  FAILED: %s" % case.differences[0]["note"])
        self.timer.settle(final=True)

    def finish(self):
        """Restores everything at the end (also after an interruption or an error)."""
        if self.original is None or self.port is None:
            return True
        try:
            self.port.drain()
            try:
                return self.keeper.restore(final=True)
            except BusClockError:
                self.port.clock = None  # the emulator's socket is gone: the wall clock it is
                return self.keeper.restore(final=True)
        except (OSError, serial.SerialException, Problem, BusClockError) as e:
            self.keeper.restore_problems.append("the port failed while restoring: %s" % e)
            return False

    # -- silence --

    def answers_where_it_should(self):
        ident, reg = self.keeper.where
        saved = self.port.register
        try:
            self.port.set_register(reg)
            self.port.drain()
            return self.dev.answers_ping(ident)
        finally:
            self.port.set_register(saved)

    def check_silence(self, case, label, rest):
        """After a reply that was due did not come: returns when the device still answers a PING
        where it should be. Else it is looked for: found somewhere else, the case moved it (a
        difference of the case); found where it should be after a while, it was silent (a
        silence of the run); either way CaseAbandoned (the rest of the case, `rest`, is not
        run). Not found: DeviceLost."""
        since = self.port.last_request_end  # the request after which it would not answer
        if self.answers_where_it_should():
            return
        expected = self.keeper.where
        wait = self.args.silence_wait
        self.say("ax12 conform: no answer during '%s' (%s) at ID %d, %d bit/s; looking for the device for up to %g s"
                 % (case.name, label, expected[0], bps_of(expected[1]), wait))
        found = self.keeper.locate(seconds=wait, passes=1)
        seconds = time.monotonic() - since
        if found is None:
            self.silences.append({"case": "%s / %s" % (case.group, case.name), "step": label,
                                  "seconds": round(seconds, 1), "found": None,
                                  "cost": "%s, and every case after it" % rest})
            raise DeviceLost("the device went silent during '%s' (%s) and did not answer a PING at any ID and baud "
                             "the run used within %.1f s (--silence-wait %g)" % (case.name, label, seconds, wait))
        place = "ID %d, %d bit/s" % (found[0], bps_of(found[1]))
        self.say("ax12 conform: found at %s after %.1f s" % (place, seconds))
        if found != expected:
            note = ("the device is not where the record leaves it (ID %d, %d bit/s): found at %s; not run: %s"
                    % (expected[0], bps_of(expected[1]), place, rest))
        else:
            self.silences.append({"case": "%s / %s" % (case.group, case.name), "step": label,
                                  "seconds": round(seconds, 1), "found": {"id": found[0], "bps": round(bps_of(found[1]))},
                                  "cost": rest})
            note = ("the device went silent: no reply to this step and none to a PING; it answered again after "
                    "%.1f s; not run: %s" % (seconds, rest))
        if not self.keeper.restore(final=False):
            raise DeviceLost("the device came back during '%s' but its settings could not be written back" % case.name)
        case.differ(label, note, silence=found == expected)
        raise CaseAbandoned(label)

    # -- one case --

    def mapping(self, case):
        """(idmap, baudmap, None) for the record, or (None, None, a reason it cannot be mapped)."""
        bus0 = case.rounds[0][0]
        servo = bus0["ids"][0]
        ids, bauds = set(), set()
        for bus, rsteps in case.rounds:
            ids.add(bus["ids"][0])
            bauds.add(bus["baud"])
            for s in rsteps:
                if s["kind"] == "exchange":
                    for text in (s["sent"], s["heard"]):
                        for pk in (P.split(R.parse_hex(text)) or [R.parse_hex(text)]):
                            ids |= ids_in(pk)
                    w = writes_of(R.parse_hex(s["sent"]))
                    if w != "reset":
                        bauds |= {v for _, a, v in w if a == T.BAUD_RATE}
                if s["kind"] == "master-baud":
                    bauds.add(s["baud"])
        idmap = {servo: self.args.id, T.ID_BROADCAST: T.ID_BROADCAST}
        spare = [i for i in self.free_ids if i not in ids]
        for i in sorted(ids - {servo, T.ID_BROADCAST}):
            if i > T.ID_MAX:
                idmap[i] = i
            elif i in self.free_ids and i != self.args.id:
                idmap[i] = i
            elif spare:
                idmap[i] = spare.pop(0)
            else:
                return None, None, "no silent ID to stand for ID %d" % i
        dev_baud = self.original[T.BAUD_RATE]
        baudmap = {bus0["baud"]: dev_baud}
        for b in bauds - {bus0["baud"]}:
            if b == dev_baud:
                return None, None, "uses Baud Rate %d, the device's own, as another baud" % b
            baudmap[b] = b
        return idmap, baudmap, None

    def plan(self, case, idmap, baudmap):
        """[(bus, steps, factory table, required, shaping)] per round, or a (kind, reason) to skip."""
        for bus, rsteps in case.rounds:
            for k, s in enumerate(rsteps):
                if s["kind"] == "exchange" and remap(R.parse_hex(s["sent"]), idmap, baudmap) is None:
                    # malformed packets carry IDs that cannot be rewritten
                    return "mapping", ("sends a malformed packet for ID %d: run with --id %d"
                                       % (bus["ids"][0], bus["ids"][0]))
                if s["kind"] == "exchange" and writes_of(R.parse_hex(s["sent"])) == "reset" and \
                        any(t["kind"] == "exchange" for t in rsteps[k + 1:]) and \
                        (idmap.get(1, 1) != 1 or baudmap.get(1, 1) != 1):
                    # a RESET that takes effect puts the device at ID 1, 1 Mbps
                    return "mapping", "steps after a RESET need the device at ID 1 and 1 Mbps"
        plans = []
        for bus, rsteps in case.rounds:
            factory = factory_table(self.profile, bus["ids"][0], bus["baud"])
            required, shaping = starting_items(rsteps, self.profile)
            differ = [a for a in required if a < T.EEPROM_SIZE and self.table[a] != factory[a]]
            if differ and not self.args.allow_eeprom:
                names = sorted({T.BY_ADDR[a].title for a in differ})
                return "eeprom", ("needs --allow-eeprom: the device's %s differ%s from the factory value%s the case "
                                  "assumes" % (", ".join(names), "s" if len(names) == 1 else "",
                                               "" if len(names) == 1 else "s"))
            plans.append((bus, rsteps, factory, required, shaping))
        if case.eeprom and not self.args.allow_eeprom:
            return "eeprom", "needs --allow-eeprom: writes the EEPROM area (%s)" % self.eeprom_items(case)
        return plans

    def run_case(self, case):
        idmap, baudmap, why = self.mapping(case)
        if why:
            case.skip("mapping", why)
            return
        self.keeper.case_ids = {i for i in idmap.values() if i != T.ID_BROADCAST} | {1}
        self.keeper.case_bauds = set(baudmap.values()) | {1}
        plans = self.plan(case, idmap, baudmap)
        if isinstance(plans, tuple):
            case.skip(*plans)
            return
        case.status = "passed"
        for attempt in (1, 2):
            try:
                for number, (bus, rsteps, factory, required, shaping) in enumerate(plans, 1):
                    label = "round %d, preparation" % number if len(plans) > 1 else "preparation"
                    started = self.prepare(case, label, factory, required, shaping)
                    if started is None:
                        return  # skipped: a conflict
                    self.run_round(case, number, len(plans), rsteps, started, idmap, baudmap)
                    if (case.eeprom or self.keeper.touched_eeprom) and not self.keeper.restore(final=False):
                        raise DeviceLost("the device could not be found again after '%s', or its settings not "
                                         "written back" % case.name)
                break
            except CaseAbandoned as abandoned:
                label = abandoned.args[0]
                if attempt == 1 and label.endswith("preparation"):
                    # lost before its steps began: run again from the start now the device is back
                    why = [d["note"] for d in case.differences if d["step"] == label]
                    case.notes.append("run again from the start: %s" % "; ".join(why))
                    case.differences, case.timings = [], []
                    self.timer.forget(case)
                    if self.silences and self.silences[-1]["case"] == "%s / %s" % (case.group, case.name):
                        self.silences[-1]["cost"] = "nothing (the case ran again once the device was back)"
                    continue
                break
        if case.differences:
            case.status = "failed"

    def eeprom_items(self, case):
        names = []
        for bus, rsteps in case.rounds:
            for s in rsteps:
                if s["kind"] == "exchange":
                    w = writes_of(R.parse_hex(s["sent"]))
                    if w == "reset":
                        names.append("RESET")
                    else:
                        names += [ITEM_AT[a].title for _, a, _ in w if a < T.EEPROM_SIZE and a in ITEM_AT]
        return ", ".join(dict.fromkeys(names)) or "EEPROM"

    # -- the starting state --

    def conflict(self, addr, value, problem):
        if addr not in self.conflicts:
            self.conflicts[addr] = {"address": addr, "item": T.BY_ADDR[addr].title, "value": value,
                                    "problem": problem, "cases": []}

    def prepare(self, case, label, factory, required, shaping):
        """Puts the device in the round's starting state: the factory's values of the items the
        round needs (required) and of those that shape replies (shaping). Returns the table read
        back, or None when a required item is in conflict (the case is then skipped)."""
        keeper, dev = self.keeper, self.dev
        keeper.touched_eeprom = False
        level = self.table[T.STATUS_RETURN_LEVEL]
        if self.table[T.REGISTERED_INSTRUCTION]:
            # a write left registered by the case before: discarded by writing 0 where the
            # device allows it, else run by ACTION (and what it wrote restored)
            reply = dev.write(T.REGISTERED_INSTRUCTION, [0], answered=level >= 2)
            if reply is None or reply.code & T.ERR_RANGE:
                dev.action()
                table = dev.read(0, T.TABLE_SIZE)
                if table is None or table[:T.EEPROM_SIZE] != self.table[:T.EEPROM_SIZE]:
                    keeper.restore(final=False)
                else:
                    keeper.table = table
        known = self.table
        written = set()
        for attempt in range(2):
            wanted = self.unlike_factory(case, None if attempt else label, known, factory, required, shaping, written)
            for addr, value in wanted:  # Status Return Level first: the others' replies depend on it
                item = T.BY_ADDR[addr]
                written.add(addr)
                if addr in self.left_by:
                    case.notes.append("%s: %s read %d, left by '%s'; written back" % (
                        label, address_name(addr), item_value(known, item), self.left_by[addr]))
                if addr < T.EEPROM_SIZE:
                    keeper.touched_eeprom = True
                answered = level >= 2
                reply = dev.write(addr, value, answered=answered)
                if addr == T.STATUS_RETURN_LEVEL:
                    level = value[0]
                if answered and reply is None:
                    self.check_silence(case, label, "the whole case")
                    self.conflict(addr, item_value(factory, item), "no reply to a WRITE of it (the device answers "
                                                                   "a PING)")
                elif answered and reply.code & ~T.ERR_CONDITIONS:
                    self.conflict(addr, item_value(factory, item), "a WRITE of it is answered with error %s"
                                  % error_words(reply.code))
            back = dev.read(0, T.TABLE_SIZE)
            if back is None:
                self.check_silence(case, label, "the whole case")
                case.differ(label + ", table read back", "the device answers a PING but no READ of its table")
                raise CaseAbandoned(label + ", table read back")
            for addr, value in wanted:
                item = T.BY_ADDR[addr]
                if addr not in self.conflicts and back[addr:addr + item.size] != value:
                    self.conflict(addr, item_value(factory, item), "reads %d after a WRITE of it"
                                  % item_value(back, item))
            known = back
            if not self.unlike_factory(case, None, back, factory, required, shaping, written):
                break
        keeper.table = list(back)
        blocked = [a for a in required if a in self.conflicts]
        if blocked:
            for a in blocked:
                self.conflicts[a]["cases"].append("%s / %s" % (case.group, case.name))
            names = ", ".join("%s = %d" % (self.conflicts[a]["item"], self.conflicts[a]["value"]) for a in blocked)
            case.differences = []
            case.skip("conflict", "its starting state needs %s, which the device will not take (see the "
                                  "starting-state conflicts)" % names)
            return None
        for a in shaping:
            if a in self.conflicts:
                case.notes.append("%s: %s is not the factory's (a starting-state conflict); the case does not "
                                  "read or write it" % (label, self.conflicts[a]["item"]))
        return back

    def unlike_factory(self, case, label, table, factory, required, shaping, written):
        """[(address, factory value bytes)] of the starting items that table does not hold at the
        factory's values and the tool may set (not in conflict, not written before in this
        preparation, the EEPROM only with --allow-eeprom), Status Return Level first. label: where
        to note a shaping EEPROM item left as the device has it (None: no note)."""
        out = []
        for addr in sorted(set(required) | set(shaping), key=lambda a: a != T.STATUS_RETURN_LEVEL):
            item = T.BY_ADDR[addr]
            value = factory[addr:addr + item.size]
            if addr in self.conflicts or addr in written or table[addr:addr + item.size] == value:
                continue
            if addr < T.EEPROM_SIZE and not self.args.allow_eeprom:
                if label and addr in shaping:
                    case.notes.append("%s: runs with the device's %s %d, not the factory's %d (--allow-eeprom "
                                      "would set it)" % (label, item.title, item_value(table, item),
                                                         item_value(factory, item)))
                continue
            out.append((addr, value))
        return out

    # -- the steps --

    def run_round(self, case, number, rounds, rsteps, started, idmap, baudmap):
        a = self.args
        table = list(started)  # the device as the record's steps change it (its own values otherwise)
        table[T.ID], table[T.BAUD_RATE] = case.rounds[number - 1][0]["ids"][0], case.rounds[number - 1][0]["baud"]
        where_id, where_baud = a.id, self.original[T.BAUD_RATE]
        self.keeper.where = (where_id, where_baud)
        checked = set()
        loose = set()  # items no record can foresee after a RESET: Goal Position (= Present Position)
        labels = ["%s%d" % ("round %d, step " % number if rounds > 1 else "step ", i)
                  for i in range(1, len(rsteps) + 1)]
        for index, s in enumerate(rsteps):
            label = labels[index]
            if s["kind"] == "master-baud":
                self.port.set_register(baudmap.get(s["baud"], s["baud"]))
                continue
            if s["kind"] != "exchange":
                continue
            sent_rec = R.parse_hex(s["sent"])
            sent = remap(sent_rec, idmap, baudmap)
            window = read_window(sent_rec)
            heard_rec = R.parse_hex(s["heard"])
            expected, mask = self.expectation(heard_rec, idmap, baudmap, window)
            w = writes_of(sent_rec)
            eeprom_bytes = T.EEPROM_SIZE if w == "reset" else sum(1 for _, ad, _ in w if ad < T.EEPROM_SIZE)
            extra = EEPROM_BYTE_S * (eeprom_bytes + 2) if eeprom_bytes else 0.0
            if eeprom_bytes:
                self.keeper.touched_eeprom = True
            stray = self.port.drain()
            if stray:
                case.differ(label, "%d byte(s) arrived after the previous step's timeout: %s" % (len(stray), hexs(stray)))
            heard = self.port.exchange(sent, len(expected), a.timeout + extra, grace=GRACE_S)
            got = heard.data
            self.verbose("%s | %s: sent %s, expected %s, heard %s" % (case.name, label, hexs(sent),
                                                                       hexs(expected) or "silence", hexs(got) or "silence"))
            ok = len(got) == len(expected) and all((g ^ e) & ~m & 0xFF == 0 for g, e, m in zip(got, expected, mask))
            if ok and expected:
                ok = all(P.parse(pk) is not None and P.parse(pk).checksum_ok for pk in P.split(got) or [got])
            if not ok:
                self.record_difference(case, label, sent, expected, mask, got, window)
            elif got:
                held = [b for k, b in enumerate(got) if mask[k] == MEASURED_CONDITIONS and b & MEASURED_CONDITIONS]
                if held:
                    case.notes.append("%s: the device reported condition bits %02X (supply, temperature or load; "
                                      "not compared)" % (label, held[0] & MEASURED_CONDITIONS))
            if got and heard.first_arrival is not None and not eeprom_bytes:  # EEPROM writes: stored, then answered
                start = heard.first_arrival - self.port.byte_s() - heard.request_end
                self.timer.add(case, label, heard, table[T.RETURN_DELAY_TIME] * T.RETURN_DELAY_UNIT_US,
                               start > a.timeout + LONGEST_RDT_S)
            if not got and eeprom_bytes:
                time.sleep(extra)
            if expected and not got:
                self.check_silence(case, label, "steps %s" % ", ".join(str(k) for k in range(index + 1, len(rsteps) + 1))
                                   if index + 1 < len(rsteps) else "the table read back")
            # where the device is now, as the record says
            before_id = table[T.ID]
            before = self.keeper.where
            effective_reset = False
            if w == "reset":
                pk = P.parse(sent_rec)
                if pk and pk.checksum_ok and not pk.params and pk.ident in (table[T.ID], T.ID_BROADCAST):
                    reply = P.parse(heard_rec) if heard_rec else None
                    effective_reset = not (reply and reply.code & T.ERR_INSTRUCTION) and not table[T.LOCK]
            apply_changes(table, s.get("changes"))
            checked |= changed_addrs(s.get("changes"))
            if w != "reset":
                checked |= {ITEM_AT[ad].addr for sid, ad, _ in w if (sid is None or sid == before_id) and ad in ITEM_AT}
            if effective_reset:
                # the whole table is the factory's now, but Goal Position (= Present Position)
                where_id, where_baud = 1, 1
                self.keeper.written.add((1, 1))
                table = factory_table(self.profile, 1, 1)
                loose = {T.GOAL_POSITION}
                checked = {it.addr for it in T.ITEMS if access(it, self.profile) == "RW"} - loose
            else:
                where_id = idmap.get(table[T.ID], table[T.ID])
                where_baud = baudmap.get(table[T.BAUD_RATE], table[T.BAUD_RATE])
            if (where_id, where_baud) != before:
                self.keeper.written.add((where_id, where_baud))
            self.keeper.where = (where_id, where_baud)
        self.check_after(case, number, rounds, table, checked, started, loose)

    def expectation(self, heard_rec, idmap, baudmap, window):
        """(expected bytes, mask) of a step's reply: mask holds per byte the bits not compared."""
        expected, mask = [], []
        for pk in (P.split(heard_rec) or ([heard_rec] if heard_rec else [])):
            m = remap(pk, idmap, baudmap, window)
            expected += m
            ignore = [0] * len(m)
            f = P.frame(m) if len(m) >= P.SHORTEST else None
            if f:
                ignore[f.header + 2] = MEASURED_CONDITIONS
            if window and len(pk) == P.SHORTEST + window[1]:
                for i in range(window[1]):
                    if window[0] + i in PRESENT | DEVICE_OWN:
                        ignore[5 + i] = 0xFF
            ignore[-1] = 0xFF  # the checksum follows them: checked for validity instead
            mask += ignore
        return expected, mask

    def record_difference(self, case, label, sent, expected, mask, got, window):
        """A step's reply that differs, with every byte that differs named when the reply has the
        expected shape (a READ's data by address, and who left a value that leaked)."""
        shown = " ".join("%02X" % e if m != 0xFF or k == len(expected) - 1 else ".."
                         for k, (e, m) in enumerate(zip(expected, mask)))
        fields = []
        fe, fg = P.frame(expected), P.frame(list(got))
        if fe and fg and len(expected) == len(got) and fe.header == fg.header:
            h = fe.header
            if got[h] != expected[h]:
                fields.append({"field": "ID", "expected": expected[h], "heard": got[h]})
            if (got[h + 2] ^ expected[h + 2]) & ~mask[h + 2] & 0xFF:
                fields.append({"field": "error", "expected": expected[h + 2], "heard": got[h + 2]})
            for k in range(h + 3, len(expected) - 1):
                if (got[k] ^ expected[k]) & ~mask[k] & 0xFF:
                    if window:
                        addr = window[0] + k - h - 3
                        entry = {"field": address_name(addr), "address": addr, "expected": expected[k],
                                 "heard": got[k]}
                        if addr in self.left_by:
                            entry["left_by"] = self.left_by[addr]
                    else:
                        entry = {"field": "parameter %d" % (k - h - 3 + 1), "expected": expected[k], "heard": got[k]}
                    fields.append(entry)
            if not fields and P.parse(list(got)) and not P.parse(list(got)).checksum_ok:
                fields.append({"field": "checksum", "expected": P.parse(list(got)).expected_checksum, "heard": got[-1]})
        if not expected:
            note = "expected silence, heard %s" % hexs(got)
        elif not got:
            note = "expected %s, heard silence" % shown
        elif fields:
            note = "; ".join(describe_field(f) for f in fields)
        else:
            note = "expected %s, heard %s" % (shown, hexs(got))
        case.differ(label, note, sent=hexs(sent), expected=shown, heard=hexs(got), bytes=fields)

    def check_after(self, case, number, rounds, table, checked, started, loose):
        """The table read back: the items the round wrote or changed must hold what the record says,
        and no other item may have changed."""
        where_id, where_baud = self.keeper.where
        label = "round %d, table after" % number if rounds > 1 else "table after"
        stray = self.port.drain()
        if stray:
            case.differ(label, "%d byte(s) arrived after the last step's timeout: %s" % (len(stray), hexs(stray)))
        self.port.set_register(where_baud)
        srl_changed = False
        if table[T.STATUS_RETURN_LEVEL] == 0:
            # to read it back: the level it had (or 1), so that restoring it costs nothing more
            self.dev.write(T.STATUS_RETURN_LEVEL, [max(1, self.original[T.STATUS_RETURN_LEVEL])], ident=where_id,
                           answered=False)
            self.keeper.touched_eeprom = True
            checked = checked - {T.STATUS_RETURN_LEVEL}
            srl_changed = True
        got = self.dev.read(0, T.TABLE_SIZE, ident=where_id)
        if got is None:
            self.check_silence(case, label, "the table read back")
            case.differ(label, "no reply to a READ of the table at ID %d, %d bit/s" % (where_id, bps_of(where_baud)))
            return
        self.keeper.table = list(got)
        expect = list(table)
        expect[T.ID], expect[T.BAUD_RATE] = where_id, where_baud
        wrong = []
        for item in T.ITEMS:
            addr = item.addr
            if addr in PRESENT | DEVICE_OWN | loose or access(item, self.profile) == "NONE" or \
                    addr in (T.ID, T.BAUD_RATE) or addr in self.conflicts:  # a conflict is named once
                continue
            if addr == T.STATUS_RETURN_LEVEL and srl_changed:
                continue
            want, have = item_value(expect, item), item_value(got, item)
            if want == have:
                for k in range(item.size):
                    self.left_by.pop(addr + k, None)
                continue
            where = "address %d" % addr if item.size == 1 else "addresses %d-%d" % (addr, addr + 1)
            if addr in checked:
                wrong.append("%s (%s) %d expected, %d read" % (item.title, where, want, have))
            elif item_value(started, item) == want:
                wrong.append("%s (%s) changed %d \u2192 %d, which the record leaves as it was"
                             % (item.title, where, want, have))
            else:
                continue
            for k in range(item.size):
                self.left_by[addr + k] = "%s / %s" % (case.group, case.name)
        if wrong:
            case.differ(label, "; ".join(wrong))

