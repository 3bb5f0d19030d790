# SPDX-License-Identifier: GPL-3.0-or-later
"""ax12-emu serve --trace (a VCD of every servo's pins, read back with vcdvcd) and --gdb (the
firmware opened to avr-gdb), through the real program and a raw pyserial client
(docs/debugging.md)."""
import os
import re
import shutil
import socket
import subprocess
import sys
import threading
import time

import pytest
import serial
import vcdvcd

import ax12_table as T
from ax12_packets import instruction_packet as packet, status_packet
from ax12_servo_port import transact
from conftest import EMU, FIRMWARE_DIR

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
sys.path.insert(0, os.path.join(REPO, "test", "support"))
import doc_samples  # noqa: E402

UNITS_PER_CYCLE = 625            # the VCD's timescale is 100 ps; a 16 MHz cycle is 62.5 ns
UNITS_PER_US = 16 * UNITS_PER_CYCLE
UNITS_PER_S = 10**10
BIT_CYCLES_1MBPS = 16
SIGNALS = ("rx", "tx", "dir", "led", "pwm_a", "pwm_b", "ocr0a", "ocr0b", "tick")
ELF = os.path.join(FIRMWARE_DIR, "ax12-ax12-atmega88.elf")
TICK_VECTOR = "__vector_12"      # TIMER1_COMPB, the control tick's interrupt (firmware/hal/tiny_isr.S)


def read_byte(port, ident, addr):
    reply = transact(port, packet(ident, T.INST_READ, [addr, 1]), 7)
    assert len(reply) == 7 and reply[2] == ident and reply[4] == 0, reply.hex()
    return reply[5]


def changes(vcd, name, start=0, end=None):
    """(time, value) of the signal's changes in [start, end), the initial dump left out."""
    tv = vcd[name].tv[1:]
    return [(t, v) for t, v in tv if t >= start and (end is None or t < end)]


def highs(vcd, name):
    """[(rise, fall)] of a 1-bit signal."""
    spans, rise = [], None
    for t, v in vcd[name].tv:
        if v == "1" and rise is None:
            rise = t
        elif v == "0" and rise is not None:
            spans.append((rise, t))
            rise = None
    return spans


def test_the_trace_shows_the_bus_the_pwm_and_the_tick_of_each_servo(emulator, tmp_path):
    """Two servos, a PING of servo 1 and a goal with torque on: in the VCD, both servos hear
    the PING on rx at 1 Mbps bit times; only servo 1 raises dir and sends on tx, only within
    its dir windows; servo 1's H-bridge toggles after the goal, servo 2's never; the control
    tick's interrupt runs 1000 times per simulated second on both."""
    trace = tmp_path / "bus.vcd"
    emu = emulator("--fast", "--ids", "1,2", "--state-dir", str(tmp_path / "state"), "--trace", str(trace))
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert transact(port, packet(1, T.INST_PING), 6) == status_packet(1, 0)
        assert transact(port, packet(1, T.INST_WRITE, [T.TORQUE_ENABLE, 1]), 6) == status_packet(1, 0)
        assert transact(port, packet(1, T.INST_WRITE, [T.GOAL_POSITION, 0x00, 0x01]), 6) == status_packet(1, 0)
        deadline = time.monotonic() + 30
        while read_byte(port, 1, T.MOVING) != 0:  # the whole move, however fast the host
            assert time.monotonic() < deadline
            time.sleep(0.01)
        time.sleep(0.3)  # and some more simulated time, for the tick's rate
    assert emu.stop() == 0
    assert "trace " + str(trace) in emu.proc.stderr.read().decode()
    text = trace.read_text()
    assert text.endswith("\n") and "$enddefinitions $end" in text
    vcd = vcdvcd.VCDVCD(str(trace))
    for servo in ("servo_1", "servo_2"):
        for s in SIGNALS:
            assert f"{servo}.{s}" in vcd.signals, (servo, s)
    end = vcd.endtime

    # The PING: the first start bit on servo 1's rx; 6 bytes of 10 bits at 16 cycles each.
    ping_start = changes(vcd, "servo_1.rx")[0][0]
    ping_end = ping_start + 6 * 10 * BIT_CYCLES_1MBPS * UNITS_PER_CYCLE
    ping_edges = changes(vcd, "servo_1.rx", ping_start, ping_end)
    assert len(ping_edges) >= 10
    assert all((t - ping_start) % (BIT_CYCLES_1MBPS * UNITS_PER_CYCLE) == 0 for t, _ in ping_edges)
    assert changes(vcd, "servo_2.rx", ping_start, ping_end) == ping_edges  # both hear it

    # The replies: servo 1's dir windows hold every tx edge of servo 1; servo 2 never drives.
    windows = highs(vcd, "servo_1.dir")
    assert len(windows) >= 4, windows  # PING, 2 WRITEs, the READs of Moving
    assert windows[0][0] > ping_end
    tx = changes(vcd, "servo_1.tx")
    assert len(tx) >= 10
    assert all(any(a <= t < b for a, b in windows) for t, _ in tx)
    for a, b in windows:
        assert changes(vcd, "servo_1.tx", a, b), (a, b)
        assert changes(vcd, "servo_2.rx", a, b), (a, b)   # servo 2 hears servo 1's reply
        assert not changes(vcd, "servo_1.rx", a + 1, b)  # a servo does not hear itself
    for s in ("tx", "dir", "pwm_a", "pwm_b", "ocr0a", "ocr0b"):
        assert changes(vcd, "servo_2." + s) == [], s

    # The goal (position 256, below the centre at 512): servo 1's H-bridge switches after the
    # torque write's reply, at 62.5 kHz (256 cycles a period).
    after_torque = windows[1][1]
    pwm = changes(vcd, "servo_1.pwm_a", after_torque) + changes(vcd, "servo_1.pwm_b", after_torque)
    assert len(pwm) > 100
    assert not changes(vcd, "servo_1.pwm_a", 0, after_torque) and not changes(vcd, "servo_1.pwm_b", 0, after_torque)
    period = 256 * UNITS_PER_CYCLE
    gaps = []
    for pin in ("pwm_a", "pwm_b"):
        rises = [t for t, v in changes(vcd, "servo_1." + pin, after_torque) if v == "1"]
        gaps += [b - a for a, b in zip(rises, rises[1:]) if b - a < 2 * period]
    # (A pin connected to the timer mid-period rises there once: a shorter gap.)
    assert gaps and gaps.count(period) >= 0.9 * len(gaps), sorted(set(gaps))[:10]
    # In steady periods (a rise 256 cycles after the previous one and before the next), a pin is
    # high OCR0x + 1 timer clocks (fast PWM, non-inverting) for a duty written to its channel.
    steady_widths = 0
    for pin, ocr in (("pwm_a", "ocr0a"), ("pwm_b", "ocr0b")):
        duties = {int(v, 2) for _, v in changes(vcd, "servo_1." + ocr)}
        spans = highs(vcd, "servo_1." + pin)
        rises = [a for a, _ in spans]
        widths = {(b - a) // UNITS_PER_CYCLE for i, (a, b) in enumerate(spans[1:-1], 1)
                  if a - rises[i - 1] == period and rises[i + 1] - a == period}
        assert widths <= {d + 1 for d in duties}, (pin, sorted(widths - {d + 1 for d in duties}))
        steady_widths += len(widths)
    assert steady_widths > 0
    assert changes(vcd, "servo_1.ocr0a") or changes(vcd, "servo_1.ocr0b")

    # The control tick: 1000 per simulated second, each its ISR's ~50 cycles.
    seconds = end / UNITS_PER_S
    assert seconds > 0.25
    for servo in ("servo_1", "servo_2"):
        ticks = highs(vcd, servo + ".tick")
        assert abs(len(ticks) - 1000 * seconds) < 10 * seconds + 3, (servo, len(ticks), seconds)
        widths = {(b - a) // UNITS_PER_CYCLE for a, b in ticks}
        assert min(widths) >= 40 and max(widths) <= 1000, widths  # (another interrupt may nest)


def test_trace_ids_traces_only_those_servos(emulator, tmp_path):
    trace = tmp_path / "one.vcd"
    emu = emulator("--fast", "--ids", "1,2,3", "--state-dir", str(tmp_path / "state"), "--trace", str(trace),
                   "--trace-ids", "2")
    with serial.Serial(emu.device, 1000000, timeout=1.0) as port:
        assert transact(port, packet(2, T.INST_PING), 6) == status_packet(2, 0)
    assert emu.stop() == 0
    vcd = vcdvcd.VCDVCD(str(trace))
    assert sorted({s.split(".")[0] for s in vcd.signals}) == ["servo_2"]
    assert len(highs(vcd, "servo_2.dir")) == 1


def test_a_trace_killed_mid_run_reads_up_to_its_last_flush(emulator, tmp_path):
    """SIGKILL: the file holds whole lines up to the last flush (at most 0.1 s of wall clock
    old), a valid VCD of what came before."""
    trace = tmp_path / "killed.vcd"
    emu = emulator("--fast", "--ids", "1,2", "--state-dir", str(tmp_path / "state"), "--trace", str(trace))
    deadline = time.monotonic() + 30
    while trace.stat().st_size < 20000:  # some flushes (the machine's speed varies)
        assert time.monotonic() < deadline
        time.sleep(0.05)
    emu.kill()
    text = trace.read_text()
    assert text.endswith("\n")
    vcd = vcdvcd.VCDVCD(str(trace))
    assert len(highs(vcd, "servo_1.tick")) > 100  # 20 KB: about 250 ticks of each servo


# gdb's line where attaching stopped the servo: "0x00001284 in main () at ..." or, at the start
# of a source line, "main () at ...".
ATTACHED = re.compile(rb"(0x[0-9a-f]+ in )?[A-Za-z_][\w.]* \(")


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def avr_gdb():
    gdb = shutil.which("avr-gdb")
    if gdb is None:
        pytest.skip("avr-gdb is not installed (Debian package gdb-avr; scripts/setup installs it)")
    return gdb


def run_gdb(gdb, port, *commands, timeout=60):
    args = [gdb, "-batch", "-nx", "-ex", f"target remote :{port}"]
    for c in commands:
        args += ["-ex", c]
    return subprocess.run(args + [ELF], capture_output=True, text=True, timeout=timeout)


def test_gdb_stops_at_the_tick_reads_registers_and_the_table_and_the_bus_runs_on(emulator, tmp_path):
    gdb = avr_gdb()
    port = free_port()
    emu = emulator("--fast", "--ids", "1,2", "--state-dir", str(tmp_path / "state"), "--gdb", f"1:{port}")
    out = run_gdb(gdb, port, f"break {TICK_VECTOR}", "continue", "info registers pc", "p/x servo.table[3]",
                  "p/x servo.table[0]@2", "bt 1", "stepi", "info registers pc", "delete",
                  "watch timebase_ms_count", "continue")
    assert out.returncode == 0, out.stderr
    text = out.stdout
    assert "Breakpoint 1, 0x" in text and f"in {TICK_VECTOR} ()" in text, text
    pcs = [line for line in text.splitlines() if line.startswith("pc ")]
    assert len(pcs) == 2, text
    assert f"<{TICK_VECTOR}>" in pcs[0]
    assert f"<{TICK_VECTOR}+" in pcs[1]  # one instruction further
    assert "$1 = 0x1" in text                   # the ID, address 3 of the control table
    assert "$2 = {0xc, 0x0}" in text            # Model Number 12
    assert "Old value = " in text and "New value = " in text, text  # the tick's ISR counts
    # gdb has gone: the servos run and answer again.
    with serial.Serial(emu.device, 1000000, timeout=1.0) as serial_port:
        for ident in (1, 2):
            assert transact(serial_port, packet(ident, T.INST_PING), 6) == status_packet(ident, 0)
    assert emu.stop() == 0


def test_while_gdb_holds_a_servo_the_whole_bus_stands_still(emulator, tmp_path):
    """gdb attached (the servo stopped) and idle: servo 2 does not answer either; once gdb has
    gone, both answer."""
    gdb = avr_gdb()
    port = free_port()
    emu = emulator("--ids", "1,2", "--state-dir", str(tmp_path / "state"), "--gdb", f"1:{port}")
    held = subprocess.Popen([gdb, "-batch", "-nx", "-ex", f"target remote :{port}", "-ex", "shell sleep 3", ELF],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 30
        line = b""
        while not ATTACHED.match(line):
            assert time.monotonic() < deadline and held.poll() is None, line
            line = held.stdout.readline()
        with serial.Serial(emu.device, 1000000, timeout=0.5) as serial_port:
            assert transact(serial_port, packet(2, T.INST_PING), 6, timeout_s=0.5) == b""
        assert held.wait(timeout=30) == 0
        with serial.Serial(emu.device, 1000000, timeout=1.0) as serial_port:
            assert transact(serial_port, packet(2, T.INST_PING), 6) == status_packet(2, 0)
            assert transact(serial_port, packet(1, T.INST_PING), 6) == status_packet(1, 0)
    finally:
        if held.poll() is None:
            held.kill()
            held.wait()
    assert emu.stop() == 0
    assert "gdb holds servo-1" in emu.proc.stderr.read().decode()


@pytest.mark.parametrize("args, names", [
    (["--gdb", "300"], "300"),
    (["--gdb", "1:0"], "1:0"),
    (["--gdb", "1:70000"], "70000"),
    (["--gdb", "5"], "5"),
    (["--trace-ids", "1"], "--trace-ids"),
    (["--trace", "x.vcd", "--trace-ids", "9"], "9"),
])
def test_bad_trace_and_gdb_options_give_one_line(args, names, tmp_path):
    out = subprocess.run([EMU, "serve", "--fast", "--firmware-dir", FIRMWARE_DIR, "--state-dir", str(tmp_path)] + args,
                         capture_output=True, text=True, timeout=20, cwd=tmp_path)
    assert out.returncode == 2
    assert out.stdout == ""
    lines = out.stderr.splitlines()
    assert len(lines) == 1 and names in lines[0], out.stderr


def test_a_gdb_port_in_use_is_refused_with_one_line(tmp_path):
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        port = busy.getsockname()[1]
        out = subprocess.run([EMU, "serve", "--fast", "--firmware-dir", FIRMWARE_DIR, "--state-dir", str(tmp_path),
                              "--gdb", f"1:{port}"], capture_output=True, text=True, timeout=20)
    assert out.returncode == 1
    assert out.stdout == ""
    assert str(port) in out.stderr and len(out.stderr.splitlines()) == 1, out.stderr


def test_a_refused_gdb_port_closes_the_control_socket_and_the_dashboard(tmp_path):
    """gdb's port is opened after the control socket and the dashboard: when it is refused, the
    emulator stops the dashboard's process and removes its socket before it exits."""
    def dashboards():
        found = set()
        for pid in os.listdir("/proc"):
            try:
                with open("/proc/%s/cmdline" % pid, "rb") as f:
                    cmdline = f.read()
            except OSError:
                continue
            if b"ax12_dashboard.py" in cmdline and str(tmp_path).encode() in cmdline:
                found.add(pid)
        return found

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        port = busy.getsockname()[1]
        out = subprocess.run([EMU, "serve", "--fast", "--firmware-dir", FIRMWARE_DIR, "--state-dir", str(tmp_path),
                              "--control", str(tmp_path / "control.sock"), "--dashboard", str(free_port()),
                              "--gdb", f"1:{port}"], capture_output=True, text=True, timeout=30)
    assert out.returncode == 1
    assert "dashboard at" in out.stderr and str(port) in out.stderr, out.stderr
    assert not (tmp_path / "control.sock").exists()
    assert dashboards() == set()


def test_sigterm_while_gdb_holds_the_bus_stops_cleanly(emulator, tmp_path):
    gdb = avr_gdb()
    port = free_port()
    emu = emulator("--fast", "--ids", "1,2", "--state-dir", str(tmp_path / "state"), "--gdb", f"2:{port}")
    held = subprocess.Popen([gdb, "-batch", "-nx", "-ex", f"target remote :{port}", "-ex", "shell sleep 5", ELF],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        line = held.stdout.readline()
        assert ATTACHED.match(line), line
        assert emu.stop() == 0
        assert "gdb holds servo-2" in emu.proc.stderr.read().decode()
    finally:
        held.kill()
        held.wait()
    assert (tmp_path / "state" / "servo-2.eeprom").stat().st_size == 512


def gdb_session_line(line):
    """A line of the documented gdb session as compared: the notes after `<-` dropped, the
    repository's path, the addresses, registers and counts of one build and moment masked."""
    line = re.sub(r"\s+<- .*$", "", line).replace(REPO + "/", "")
    # Where the servo was: attaching, and where the watched write happened.
    line = re.sub(r"^(0x[0-9a-f]{8} in )?[\w.]+ \(.*\) at \S+:\d+$", "LOCATION", line)
    line = re.sub(r"^\d+\t.*$", "SOURCE LINE", line)
    line = re.sub(r"0x[0-9a-f]{8}", "ADDR", line)
    line = re.sub(r"^Breakpoint (\d+) at 0x[0-9a-f]+$", r"Breakpoint \1 at ADDR", line)
    line = re.sub(r"^(pc|SP|SREG|r24)\s+.*$", r"\1 VALUE", line)
    line = re.sub(r"^(Old|New) value = .*$", r"\1 value = VALUE", line)
    return re.sub(r"^\$4 = \d+$", "$4 = COUNT", line)


def test_the_documented_gdb_session_runs_as_docs_debugging_md_shows(emulator, tmp_path):
    """docs/debugging.md's session, its `(gdb)` commands taken from the doc and run in avr-gdb
    against `serve --ids 1,2 --mcu atmega328p --gdb 1` while a client writes Goal Position now and
    then (so that the watchpoint fires): every command succeeds and prints what the doc shows."""
    gdb = avr_gdb()
    port = free_port()
    link = tmp_path / "ax12"
    emu = emulator("--ids", "1,2", "--mcu", "atmega328p", "--state-dir", str(tmp_path / "state"), "--link",
                   str(link), "--gdb", f"1:{port}")
    _, _, sample = doc_samples.samples()["gdb-session"]
    elf_line, commands = sample[0], [re.sub(r"\s+<- .*$", "", line)[len("(gdb) "):] for line in sample
                                     if line.startswith("(gdb) ")]
    assert elf_line.startswith("$ avr-gdb build/firmware/") and commands[0] == "target remote :1234", sample[:2]
    elf = os.path.join(FIRMWARE_DIR, os.path.basename(elf_line.split()[-1]))
    args = [gdb, "-batch", "-nx"]
    for command in commands:
        args += ["-ex", "echo (gdb) %s\\n" % command, "-ex", command.replace(":1234", ":%d" % port)]
    done = threading.Event()

    def client():
        """Goal Position changes every 0.3 s from when gdb stopped servo 1 the fourth time (the
        breakpoint after `stepi`: the table was shown with its power-up goal), the bus willing."""
        holds = 0
        while holds < 4:
            line = emu.proc.stderr.readline().decode()
            if not line:
                return
            holds += "gdb holds servo-1" in line
        goal = 600
        with serial.Serial(str(link), 1000000, timeout=0.2) as bus:
            while not done.is_set():
                bus.write(packet(1, T.INST_WRITE, [T.GOAL_POSITION, goal & 0xFF, goal >> 8]))
                bus.read(6)
                goal = 1300 - goal
                time.sleep(0.3)
    writer = threading.Thread(target=client, daemon=True)
    writer.start()
    try:
        out = subprocess.run(args + [elf], capture_output=True, text=True, timeout=120)
    finally:
        done.set()
        writer.join(timeout=5)
    assert out.returncode == 0, out.stdout + out.stderr
    for trouble in ("doesn't know", "corrupt stack", "Num pushes", "Cannot", "rror"):
        assert trouble not in out.stdout + out.stderr, out.stdout + out.stderr
    doc_samples.check("gdb-session", elf_line + "\n" + out.stdout, gdb_session_line)
