"""scripts/bench --load: real time on a busy machine (docs/emulator.md "Real time on a busy
machine"). Quiet, then under busy processes of its own (one per CPU, each a `while True` loop in
a session of its own, as programs started from another terminal or a desktop are: Linux's
autogroups share the CPU between sessions):
- DynamixelSDK's ping through ax12-emu serve behind the default adapter: its round trip
  p50 / p99 / max, and the emulator's own figures of the same run (--stats: the delay of the
  client's bytes to the simulated bus, how late the replies reached the pty, its worst lag, the
  scheduling policy it held);
- the same round trip through a bare pty with an echo process on the master (at the real-time
  policy when allowed, like the emulator's reader): what the kernel's pty worker and the
  client's own scheduling cost with no emulator at all;
- the DynamixelSDK client suite (test/clients/test_dynamixel_sdk.py through pytest) N times
  under the load: runs passed, and the worst figures of its emulators.
Wall-clock figures: they say the machine's load beside them (load average, CPUs)."""
import os
import re
import select
import signal
import statistics
import subprocess
import sys
import tempfile
import termios
import time
import tty

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SUITE = os.path.join(REPO, "test", "clients", "test_dynamixel_sdk.py")
PING = bytes([0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB])  # PING ID 1
TIMING = re.compile(r"timing: .*client to bus delay p50 (?P<in50>[\d.]+) / p99 (?P<in99>[\d.]+) / max (?P<inmax>[\d.]+) ms "
                    r"over (?P<writes>\d+) writes.*hand-overs to the client late p50 (?P<out50>[\d.]+) / p99 "
                    r"(?P<out99>[\d.]+) / max (?P<outmax>[\d.]+) ms.*worst lag (?P<lag>[\d.]+) ms; behind real time: "
                    r"(?P<yields>\d+) yields.*dropped (?P<drops>\d+) times.*; scheduling: (?P<policy>.*)$", re.M)
ECHO = r"""
import os, sys
try:
    os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(11))
except OSError:
    pass
fd = int(sys.argv[1])
while True:
    try:
        data = os.read(fd, 4096)
    except OSError:  # EIO: the client side closed
        break
    if not data:
        break
    os.write(fd, data)
"""


def quantiles(values):
    v = sorted(values)
    return {"p50": v[len(v) // 2], "p99": v[min(len(v) - 1, int(0.99 * len(v)))], "max": v[-1]}


def emulator_timing(stderr_text):
    """The --stats timing line of one emulator, as numbers (None without one)."""
    m = TIMING.search(stderr_text)
    if not m:
        return None
    t = {k: float(v) for k, v in m.groupdict().items() if k != "policy"}
    t["policy"] = m.group("policy")
    return t


class Hogs:
    """count busy processes, each in a session of its own; stopped by their process ids."""

    def __init__(self, count):
        self.procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"], start_new_session=True)
                      for _ in range(count)]
        time.sleep(0.5)  # let the scheduler see them

    def stop(self):
        for p in self.procs:
            p.kill()
            p.wait()


def sdk_pings(emu, fw, count):
    """count DynamixelSDK pings of servo 1 behind the default adapter: round trips in ms (a
    failed one counts as the SDK's timeout it waited), failures, and the emulator's timing."""
    from dynamixel_sdk import PacketHandler, PortHandler
    state = tempfile.TemporaryDirectory(prefix="ax12-bench-load-")
    proc = subprocess.Popen([emu, "serve", "--ids", "1", "--state-dir", state.name, "--stats", "--firmware-dir", fw],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        if not line.startswith("ready: "):
            raise RuntimeError("ax12-emu serve did not start: " + line + proc.stderr.read())
        port = PortHandler(line.split(": ", 1)[1].strip())
        if not port.openPort() or not port.setBaudRate(1000000):
            raise RuntimeError("cannot open the emulator's pty")
        packet = PacketHandler(1.0)
        times, failed = [], 0
        for _ in range(count):
            t0 = time.perf_counter()
            _, result, _ = packet.ping(port, 1)
            times.append((time.perf_counter() - t0) * 1e3)
            failed += result != 0
        port.closePort()
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
        state.cleanup()
    return times, failed, emulator_timing(err)


def bare_pty_round_trips(count):
    """count 6-byte round trips through a bare pty: an echo process on the master, the client
    busy-polling the slave without sleeping as DynamixelSDK does. In ms."""
    master, slave = os.openpty()
    echo = subprocess.Popen([sys.executable, "-c", ECHO, str(master)], pass_fds=(master,))
    os.close(master)
    try:
        tty.setraw(slave)
        attrs = termios.tcgetattr(slave)
        attrs[4] = attrs[5] = termios.B1000000
        termios.tcsetattr(slave, termios.TCSANOW, attrs)
        os.set_blocking(slave, False)
        times = []
        for _ in range(count):
            t0 = time.perf_counter()
            os.write(slave, PING)
            got = b""
            while len(got) < len(PING) and time.perf_counter() - t0 < 1.0:
                try:
                    got += os.read(slave, 64)
                except BlockingIOError:
                    pass
            times.append((time.perf_counter() - t0) * 1e3)
            while select.select([slave], [], [], 0)[0]:
                os.read(slave, 4096)
    finally:
        os.close(slave)
        echo.kill()
        echo.wait()
    return times


def client_suite(build, basetemp):
    """One run of the DynamixelSDK client suite: (passed, failed test names, worst timing of its
    emulators: the largest of each figure, pytest's output with the failed tests' emulators'
    stderr when it failed)."""
    build = os.path.abspath(build)  # pytest runs in test/clients
    env = dict(os.environ, AX12_EMU=os.path.join(build, "model", "tools", "ax12-emu"),
               AX12_FIRMWARE_DIR=os.path.join(build, "firmware"),
               PYTHONPATH=os.pathsep.join([os.path.join(build, "python"), os.path.join(REPO, "python")]))
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-c", os.path.join(REPO, "test", "clients", "pytest.ini"),
                          "--basetemp", basetemp, SUITE], cwd=os.path.join(REPO, "test", "clients"), env=env,
                         capture_output=True, text=True)
    failed = re.findall(r"^FAILED (\S+)", run.stdout, re.M)
    worst = {}
    report = run.stdout + run.stderr if run.returncode != 0 else ""
    for root, _, files in os.walk(basetemp):
        if "emulator.stderr" in files:
            with open(os.path.join(root, "emulator.stderr"), errors="replace") as f:
                text = f.read()
            t = emulator_timing(text)
            for key, value in (t or {}).items():
                if key != "policy":
                    worst[key] = max(worst.get(key, 0.0), value)
            if report:
                report += "\n--- %s\n%s" % (root, "\n".join(line for line in text.splitlines() if " servo-" not in line))
    return run.returncode == 0, failed, worst, report


def load_average():
    with open("/proc/loadavg") as f:
        return float(f.read().split()[0])


def run_load(build, runs, pings, row, r, failures_log):
    """The figures of scripts/bench --load into row() / r; returns lines to print after the table.
    The failed suite runs' output goes to failures_log."""
    emu = os.path.join(build, "model", "tools", "ax12-emu")
    fw = os.path.join(build, "firmware")
    cpus = os.cpu_count() or 1
    lines = []
    phases = {}
    for phase in ("quiet", "loaded"):
        hogs = Hogs(cpus) if phase == "loaded" else None
        try:
            before = load_average()
            times, failed, timing = sdk_pings(emu, fw, pings)
            bare = bare_pty_round_trips(pings)
            suite = None
            if phase == "loaded":
                suite = []
                with tempfile.TemporaryDirectory(prefix="ax12-bench-load-suite-") as tmp:
                    for i in range(runs):
                        suite.append(client_suite(build, os.path.join(tmp, "run%d" % i)))
                        print("bench --load: suite run %d of %d: %s" % (i + 1, runs, "passed" if suite[-1][0] else
                                                                       "FAILED " + " ".join(suite[-1][1])),
                              file=sys.stderr, flush=True)
            after = load_average()
        finally:
            if hogs:
                hogs.stop()
        phases[phase] = (times, failed, timing, bare, suite, before, after)

    label = {"quiet": "quiet (no busy process of its own)", "loaded": "loaded (%d busy processes)" % cpus}
    for phase, (times, failed, timing, bare, suite, before, after) in phases.items():
        sec = "load: " + label[phase]
        row(sec, "load average before / after", "%.1f / %.1f" % (before, after), "", "", None)
        r["load_%s_loadavg" % phase] = after
        q = quantiles(times)
        for k in ("p50", "p99", "max"):
            row(sec, "DynamixelSDK ping (u2d2), %s" % k, q[k], "ms", "", "load_%s_ping_%s_ms" % (phase, k))
        row(sec, "DynamixelSDK pings without a reply", failed, "of %d" % pings, "0", "load_%s_ping_failures" % phase)
        b = quantiles(bare)
        row(sec, "bare pty echo round trip p50 / p99 / max", "%.3f / %.3f / %.3f" % (b["p50"], b["p99"], b["max"]),
            "ms", "", None)
        for k in ("p50", "p99", "max"):
            r["load_%s_bare_pty_%s_ms" % (phase, k)] = b[k]
        if timing:
            row(sec, "emulator: scheduling", timing["policy"], "", "", None)
            row(sec, "emulator: client to bus delay p50 / p99 / max",
                "%.3f / %.3f / %.3f" % (timing["in50"], timing["in99"], timing["inmax"]), "ms", "", None)
            row(sec, "emulator: replies to the pty late p50 / p99 / max",
                "%.3f / %.3f / %.3f" % (timing["out50"], timing["out99"], timing["outmax"]), "ms", "", None)
            row(sec, "emulator: worst lag", timing["lag"], "ms", "", "load_%s_worst_lag_ms" % phase)
            for k in ("in50", "in99", "inmax", "out50", "out99", "outmax"):
                r["load_%s_emulator_%s_ms" % (phase, k)] = timing[k]
        if suite is not None:
            passed = sum(1 for ok, _, _, _ in suite if ok)
            row(sec, "DynamixelSDK client suite: runs passed", "%d of %d" % (passed, len(suite)), "", "all", None)
            r["load_suite_runs"] = len(suite)
            r["load_suite_runs_passed"] = passed
            worst = {}
            for _, _, w, _ in suite:
                for key, value in w.items():
                    worst[key] = max(worst.get(key, 0.0), value)
            if worst:
                row(sec, "suite's emulators, worst: client to bus p99 / max",
                    "%.3f / %.3f" % (worst["in99"], worst["inmax"]), "ms", "", None)
                row(sec, "suite's emulators, worst: replies late p99 / max",
                    "%.3f / %.3f" % (worst["out99"], worst["outmax"]), "ms", "", None)
                row(sec, "suite's emulators, worst lag", worst["lag"], "ms", "", "load_suite_worst_lag_ms")
                r["load_suite_worst_to_bus_max_ms"] = worst["inmax"]
                r["load_suite_worst_late_max_ms"] = worst["outmax"]
            for i, (ok, failed_tests, _, report) in enumerate(suite):
                if not ok:
                    lines.append("run %d failed: %s" % (i + 1, ", ".join(failed_tests) or "(see pytest)"))
                    with open(failures_log, "a") as f:
                        f.write("=== run %d\n%s\n" % (i + 1, report))
            if passed < len(suite):
                lines.append("pytest's output of the failed runs, with their emulators' --stats: %s" % failures_log)
    quiet_p99 = quantiles(phases["quiet"][0])["p99"]
    loaded_p99 = quantiles(phases["loaded"][0])["p99"]
    row("load: ratio", "DynamixelSDK ping p99, loaded / quiet", loaded_p99 / quiet_p99, "", "<= 2",
        "load_ping_p99_ratio")
    return lines
