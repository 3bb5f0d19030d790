"""The figures of scripts/bench, gathered from the build: sizes (avr-size), cycle-exact wire and
firmware timing (ax12-bench, simulated cycles), simulation speed (wall clock, median of several
runs), and real clients through the pty of ax12-emu serve. Prints a table with each goal beside
its figure and writes bench.json (one key per figure, plain numbers)."""
import argparse
import json
import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time

CYCLES_PER_US = 16.0
FLASH_ATMEGA88 = 8192
RAM_ATMEGA88 = 1024


def run_json(cmd):
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def avr_size(elf):
    out = subprocess.run(["avr-size", "-A", elf], check=True, capture_output=True, text=True).stdout
    sections = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith(".") and parts[1].isdigit():
            sections[parts[0]] = int(parts[1])
    flash = sections.get(".text", 0) + sections.get(".data", 0)
    ram = sections.get(".data", 0) + sections.get(".bss", 0) + sections.get(".noinit", 0)
    return flash, ram


class Serve:
    """ax12-emu serve in real time with a fresh state directory; yields the device path."""

    def __init__(self, emu, firmware_dir, ids, extra=()):
        self.state = tempfile.TemporaryDirectory(prefix="ax12-bench-")
        env = dict(os.environ, AX12_FIRMWARE_DIR=firmware_dir)
        self.proc = subprocess.Popen([emu, "serve", "--ids", ids, "--state-dir", self.state.name, "--stats", *extra],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        line = self.proc.stdout.readline()
        if not line.startswith("ready: "):
            self.proc.kill()
            raise RuntimeError("ax12-emu serve did not start: " + line + self.proc.stderr.read())
        self.device = line.split(": ", 1)[1].strip()

    def stop(self):
        self.proc.send_signal(signal.SIGTERM)
        _, err = self.proc.communicate(timeout=30)
        self.state.cleanup()
        stats = {}
        m = re.search(r"simulated ([\d.]+) s at ([\d.]+)x real time; worst lag ([\d.]+) ms", err)
        if m:
            stats = {"simulated_s": float(m.group(1)), "speed": float(m.group(2)), "worst_lag_ms": float(m.group(3))}
        return stats


def sdk_port(device):
    from dynamixel_sdk import PacketHandler, PortHandler
    port = PortHandler(device)
    if not port.openPort() or not port.setBaudRate(1000000):
        raise RuntimeError("cannot open " + device)
    return port, PacketHandler(1.0)


def sdk_ping_median_ms(emu, firmware_dir, pings):
    serve = Serve(emu, firmware_dir, "1")
    try:
        port, packet = sdk_port(serve.device)
        times = []
        for _ in range(pings):
            t0 = time.perf_counter()
            _, result, _ = packet.ping(port, 1)
            times.append((time.perf_counter() - t0) * 1e3)
            if result != 0:
                raise RuntimeError("ping failed")
        port.closePort()
    finally:
        serve.stop()
    return statistics.median(times)


def sdk_client_loop(emu, firmware_dir, servos, seconds):
    """One SYNC_WRITE of goal positions plus a READ of Present Position from every servo,
    repeated through the pty in real time; then every servo's goal is checked."""
    from dynamixel_sdk import GroupSyncWrite
    serve = Serve(emu, firmware_dir, "1-%d" % servos)
    try:
        port, packet = sdk_port(serve.device)
        for i in range(1, servos + 1):
            packet.write1ByteTxRx(port, i, 24, 1)  # torque on
        loops, failures, goals = 0, 0, {}
        t_end = time.perf_counter() + seconds
        while time.perf_counter() < t_end:
            sync = GroupSyncWrite(port, packet, 30, 2)
            for i in range(1, servos + 1):
                goals[i] = 400 + (i * 7 + (loops // 20) * 200) % 300
                sync.addParam(i, [goals[i] & 0xFF, goals[i] >> 8])
            sync.txPacket()
            for i in range(1, servos + 1):
                _, result, _ = packet.read2ByteTxRx(port, i, 36)
                failures += result != 0
            loops += 1
        elapsed = seconds
        time.sleep(1.5)  # let every servo arrive
        reached = 0
        for i in range(1, servos + 1):
            position, result, _ = packet.read2ByteTxRx(port, i, 36)
            reached += result == 0 and abs(position - goals[i]) <= 4
        port.closePort()
    finally:
        stats = serve.stop()
    return {"loops_per_s": loops / elapsed, "read_failures": failures, "servos_at_goal": reached, **stats}


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--build", required=True)
    ap.add_argument("--out", default="bench.json")
    ap.add_argument("--quick", action="store_true", help="fewer repetitions")
    a = ap.parse_args()
    fw = os.path.join(a.build, "firmware")
    bench = os.path.join(a.build, "model", "tools", "ax12-bench")
    emu = os.path.join(a.build, "model", "tools", "ax12-emu")
    elf = os.path.join(fw, "ax12-ax12-atmega88.elf")
    runs = 1 if a.quick else 3
    r = {}
    rows = []

    def row(section, name, value, unit, goal="", key=None):
        rows.append((section, name, value, unit, goal))
        if key:
            r[key] = value

    for mcu in ("atmega88", "atmega328p"):
        flash, ram = avr_size(os.path.join(fw, "ax12-ax12-%s.elf" % mcu))
        stack = run_json([bench, "stack", os.path.join(fw, "ax12-ax12-%s.elf" % mcu)])["stack_deepest_bytes"]
        goal88 = mcu == "atmega88"
        row("size", "%s flash" % mcu, flash, "B", "<= %d (75 %%)" % (FLASH_ATMEGA88 * 3 // 4) if goal88 else "",
            "%s_flash_bytes" % mcu)
        row("size", "%s static RAM" % mcu, ram, "B", "", "%s_static_ram_bytes" % mcu)
        row("size", "%s deepest stack" % mcu, stack, "B", "", "%s_stack_bytes" % mcu)
        row("size", "%s RAM incl. stack" % mcu, ram + stack, "B", "<= %d (75 %%)" % (RAM_ATMEGA88 * 3 // 4) if goal88 else "",
            "%s_ram_with_stack_bytes" % mcu)

    t = run_json([bench, "turnaround", elf, "200"])
    for kind, label in (("ping", "PING"), ("read2", "2-byte READ"), ("write2", "2-byte WRITE")):
        for stat in ("median", "worst"):
            cycles = t["%s_%s_cycles" % (kind, stat)]
            row("reply at RDT 0", "%s %s" % (label, stat), cycles, "cycles", "<= 160 (10 us)", "turnaround_%s_%s_cycles" % (kind, stat))
            r["turnaround_%s_%s_us" % (kind, stat)] = cycles / CYCLES_PER_US
        row("reply at RDT 0", "%s jitter" % label, t["%s_worst_cycles" % kind] - t["%s_min_cycles" % kind], "cycles",
            "a few", "turnaround_%s_jitter_cycles" % kind)

    rdt = run_json([bench, "rdt", elf])
    for key, value in rdt.items():
        r[key] = value
    row("Return Delay Time", "PING, worst error over RDT 1..254", rdt["rdt_worst_error_us"], "us", "within +-2",
        "rdt_worst_error_us")
    for v in (1, 2, 5, 10, 50, 100, 250, 254):
        row("Return Delay Time", "RDT %d: PING / 2-byte READ worst error" % v,
            "%.2f / %.2f" % (rdt["rdt_%d_worst_error_us" % v], rdt["rdt_%d_read_worst_error_us" % v]), "us",
            "within +-2")

    s = run_json([bench, "sustained", elf, "30", "1" if a.quick else "3"])
    row("sustained 1 Mbps", "SYNC_WRITE x 30 servos, simulated", s["simulated_s"], "s", "", "sustained_simulated_s")
    row("sustained 1 Mbps", "wire busy", s["wire_busy_fraction"], "", "1.0", "sustained_wire_busy_fraction")
    lost = s["bytes_lost_uart_overrun"] + max(s["bytes_dropped_by_firmware"], 0)
    row("sustained 1 Mbps", "bytes lost", lost, "B", "0", "sustained_bytes_lost")
    row("sustained 1 Mbps", "goals wrong after the load", s["goals_wrong_after_load"], "servos", "0",
        "sustained_goals_wrong")
    # timer_ticks_expected counts whole milliseconds of the window: a servo may see one more.
    row("sustained 1 Mbps", "timer ticks missed", max(0, s["timer_ticks_expected"] - s["timer_ticks"]), "ticks", "0",
        "sustained_timer_ticks_missed")
    if s["control_ticks_run"] >= 0:
        row("sustained 1 Mbps", "control ticks missed", max(0, s["timer_ticks_expected"] - s["control_ticks_run"]),
            "ticks", "0", "sustained_control_ticks_missed")

    try:
        aw = run_json([bench, "awake", elf])
        row("firmware CPU", "awake share, idle (torque off)", aw["awake_idle"], "", "", "awake_idle")
        row("firmware CPU", "awake share, control loop holding", aw["awake_control_loop"], "", "",
            "awake_control_loop")
        row("firmware CPU", "awake share, full 1 Mbps bus load", aw["awake_full_bus_load"], "", "< 1",
            "awake_full_bus_load")
    except subprocess.CalledProcessError as e:
        print("bench: awake share not measured: %s" % e, file=sys.stderr)

    for n in (1, 18, 30):
        speeds = [run_json([bench, "speed", elf, str(n), "1"]) for _ in range(runs)]
        idle = statistics.median(x["idle_sim_s_per_wall_s"] for x in speeds)
        loaded = statistics.median(x["loaded_sim_s_per_wall_s"] for x in speeds)
        row("simulation speed", "%d servos, unthrottled, idle" % n, idle, "x real time", ">= 1", "speed_%d_idle_fast" % n)
        row("simulation speed", "%d servos, unthrottled, client loop" % n, loaded, "x real time", ">= 1",
            "speed_%d_loaded_fast" % n)

    ping = sdk_ping_median_ms(emu, fw, 50 if a.quick else 200)
    row("real clients", "DynamixelSDK ping, median", ping, "ms", "", "sdk_ping_median_ms")
    for n in (1, 18, 30):
        loop = sdk_client_loop(emu, fw, n, 3 if a.quick else 6)
        row("real clients", "%d servos: SYNC_WRITE + %d READs" % (n, n), loop["loops_per_s"], "loops/s", "",
            "sdk_loop_%d_loops_per_s" % n)
        row("real clients", "%d servos: real-time factor (throttled)" % n, loop.get("speed", float("nan")),
            "x real time", ">= 1", "sdk_loop_%d_speed" % n)
        row("real clients", "%d servos: worst lag" % n, loop.get("worst_lag_ms", float("nan")), "ms", "",
            "sdk_loop_%d_worst_lag_ms" % n)
        row("real clients", "%d servos: at goal after the loop" % n, loop["servos_at_goal"], "servos", "%d" % n,
            "sdk_loop_%d_servos_at_goal" % n)

    report = os.path.join(os.path.dirname(os.path.abspath(__file__)), "model_report")
    if os.path.exists(report):
        try:
            m = run_json([report, "--json", "--lab", os.path.join(a.build, "model", "tools", "ax12-lab")])
            for key, value in sorted(m.items()):
                r["model_" + key] = value
                if not key.endswith("_ratio"):
                    ratio = m.get(key + "_ratio")
                    row("model (scripts/model_report)", key.replace("_", " "), value, "",
                        "manual x %.3f" % ratio if ratio is not None else "")
        except (subprocess.CalledProcessError, json.JSONDecodeError, IndexError) as e:
            print("bench: model_report failed: %s" % e, file=sys.stderr)

    section = None
    print("%-18s %-42s %14s  %-12s %s" % ("", "figure", "value", "unit", "goal"))
    for sec, name, value, unit, goal in rows:
        if sec != section:
            print("\n" + sec)
            section = sec
        text = ("%.3f" % value) if isinstance(value, float) else str(value)
        print("  %-58s %14s  %-12s %s" % (name, text, unit, goal))
    with open(a.out, "w") as f:
        json.dump(r, f, indent=1, sort_keys=True)
    print("\nbench: wrote %s" % a.out)


if __name__ == "__main__":
    main()
