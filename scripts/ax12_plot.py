# SPDX-License-Identifier: GPL-3.0-or-later
"""Figures of the emulated AX-12 (docs/control.md), from runs of the real firmware ELF in
simavr driving the plant (`ax12-lab KIND` writes CSV read through the protocol).

    scripts/ax12 plot KIND --out FILE.png [--lab PATH] [--csv FILE]

KIND: step | compliance | speed-load | heating.
"""
import argparse
import csv
import io
import math
import os
import subprocess
import sys

KINDS = {
    "step": "step responses (goal 412 -> 612) for several compliance slopes; 17 acts as 32",
    "compliance": "Present Load vs position error as the firmware applies it (external torque swept)",
    "speed-load": "wheel-mode speed vs load torque at full drive, several supplies",
    "heating": "temperature under stall until the overheating alarm shuts the torque off",
}

DEG_PER_COUNT = 300.0 / 1024.0


def run_lab(lab, kind, extra):
    proc = subprocess.run([lab, kind] + extra, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if proc.returncode != 0:
        sys.exit(f"ax12 plot: {lab} {kind} failed: {proc.stderr.strip()}")
    return proc.stdout


def rows(text):
    return list(csv.DictReader(io.StringIO(text)))


def group(data, key):
    out = {}
    for r in data:
        out.setdefault(r[key], []).append(r)
    return out


def plot_step(plt, data):
    fig, ax = plt.subplots(figsize=(9, 5.5))
    by_slope = group(data, "slope")
    styles = {"17": dict(linestyle="none", marker="o", markersize=3, markevery=6, color="black")}
    for slope, rs in by_slope.items():
        t = [float(r["t_ms"]) for r in rs]
        pos = [(int(r["position"]) - 612) * DEG_PER_COUNT for r in rs]
        label = f"slope {slope}" + (" (acts as 32: same samples)" if slope == "17" else "")
        ax.plot(t, pos, label=label, **styles.get(slope, dict(linewidth=1.6)))
    ax.axhline(0.0, color="grey", linewidth=0.8, linestyle=":")
    ax.set_title("Step response: goal 412 -> 612 (58.6 deg), Moving Speed 0, 9.6 V, no load\n"
                 "Present Position read through the protocol every 2 ms; margin 0, punch 32")
    ax.set_xlabel("time since the goal write (ms)")
    ax.set_ylabel("Present Position - goal (deg)")
    ax.set_xlim(0, 800)
    ax.grid(True, alpha=0.3)
    ax.legend(title="compliance slope (CW = CCW)", loc="lower right")
    inset = ax.inset_axes([0.3, 0.1, 0.27, 0.38])
    for slope, rs in by_slope.items():
        t = [float(r["t_ms"]) for r in rs]
        err = [int(r["position"]) - 612 for r in rs]
        inset.plot(t, err, **styles.get(slope, dict(linewidth=1.2)))
    inset.set_xlim(200, 600)
    inset.set_ylim(-12, 3)
    inset.set_title("settling (counts)", fontsize=8)
    inset.tick_params(labelsize=7)
    inset.grid(True, alpha=0.3)
    return fig


def compliance_law(error, margin, punch, slope, limit=1023):
    """The law as implemented (dxl_control_compliance_drive): drive for goal - position."""
    mag = abs(error)
    if mag <= margin:
        return 0
    shift = 1
    while shift < 8 and (1 << shift) < slope:
        shift += 1
    step = min(punch, limit)
    drive = min(limit, step + (((limit - step) * (mag - margin)) >> shift))
    return drive if error > 0 else -drive


def plot_compliance(plt, data):
    fig, ax = plt.subplots(figsize=(9, 6))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (slope, rs) in enumerate(group(data, "slope").items()):
        c = colors[i % len(colors)]
        err = [int(r["error"]) for r in rs]
        load = [int(r["present_load"]) for r in rs]
        ax.plot(err, load, linestyle="none", marker=".", markersize=4, color=c,
                label=f"slope {slope}: measured")
        xs = list(range(-200, 201))
        ax.plot(xs, [compliance_law(x, 1, 32, int(slope)) for x in xs], color=c, linewidth=1, alpha=0.7,
                label=f"slope {slope}: the law")
    ax.axhline(0, color="grey", linewidth=0.6)
    ax.axvline(0, color="grey", linewidth=0.6)
    ax.set_xlim(-200, 200)
    ax.set_ylim(-1100, 1100)
    ax.set_title("Compliance as applied: Present Load vs position error, 9.6 V\n"
                 "goal 512, margins 1, punch 32, Torque Limit 1023;\n"
                 "an external torque swept 0 -> +2 -> -2 -> 0 N m over 8 s pushes the output off the goal")
    ax.set_xlabel("goal - Present Position (counts; 1 count = 0.29 deg; + = output CW of goal)")
    ax.set_ylabel("Present Load (signed drive, 1023 = full; + = CCW)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, ncol=2, loc="upper left")
    ax.text(0.99, 0.02, "lines: the law of dxl_control.c; dots: Present Load read while held.\n"
            "The gears hold more than they lift: 2 N m is held with ~70 % drive,\n"
            "so the saturated ends of the law are not reached here",
            transform=ax.transAxes, ha="right", va="bottom", fontsize=8, color="dimgrey")
    return fig


def plot_speed_load(plt, data):
    fig, ax = plt.subplots(figsize=(9, 5.5))
    for supply, rs in group(data, "supply_v").items():
        load = [float(r["load_nm"]) for r in rs]
        rpm = [float(r["present_speed"]) * 0.111 for r in rs]
        plant = [float(r["plant_rpm"]) for r in rs]
        line, = ax.plot(load, rpm, marker="o", markersize=4, label=f"{float(supply):g} V: Present Speed")
        ax.plot(load, plant, linestyle="--", color=line.get_color(), linewidth=1,
                label=f"{float(supply):g} V: shaft (plant)")
    ax.plot([1.177, 1.618], [0, 0], linestyle="none", marker="X", markersize=10, color="black",
            clip_on=False, zorder=5, label="manual: stall torque 7 V, 10 V")
    ax.plot([0, 0], [37.2, 51.0], linestyle="none", marker="D", markersize=7, color="black",
            clip_on=False, zorder=5, label="manual: no-load speed 7 V, 10 V")
    ax.set_title("Speed vs load: wheel mode, Moving Speed 1023 (full drive) against a constant load\n"
                 "supply at the connector; Present Speed averaged over 300 ms (x 0.111 rpm)")
    ax.set_xlabel("load torque against the motion (N m)")
    ax.set_ylabel("output speed (rpm)")
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def plot_heating(plt, data):
    fig, ax = plt.subplots(figsize=(9, 5.5))
    t = [float(r["t_s"]) for r in data]
    ax.plot(t, [int(r["present_temperature"]) for r in data], label="Present Temperature (protocol)",
            linewidth=2)
    ax.plot(t, [float(r["case_c"]) for r in data], linestyle="--", label="case / sensor node (plant)")
    ax.plot(t, [float(r["winding_c"]) for r in data], linestyle=":", label="winding (plant)")
    limit = int(data[0]["limit"])
    ax.axhline(limit, color="red", linewidth=1, label=f"Highest Limit Temperature ({limit} degC)")
    off = next((float(r["t_s"]) for r in data if r["torque_enable"] == "0"), None)
    if off is not None:
        ax.axvline(off, color="black", linewidth=1, linestyle="-.",
                   label=f"overheating alarm: torque off at {off:.0f} s")
    ax2 = ax.twinx()
    ax2.plot(t, [float(r["current_a"]) for r in data], color="grey", linewidth=1, label="supply current")
    ax2.set_ylabel("supply current (A)", color="grey")
    ax2.set_ylim(0, 2.0)
    ax.set_title("Heating under stall: full drive against a stiff spring, 9.6 V (0.1 ohm), 25 degC air\n"
                 "until the overheating alarm turns the torque off (Alarm Shutdown = overheating)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("temperature (degC)")
    ax.grid(True, alpha=0.3)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper left")
    return fig


PLOTTERS = {"step": plot_step, "compliance": plot_compliance, "speed-load": plot_speed_load,
            "heating": plot_heating}


def main(argv=None):
    kinds = "\n".join(f"  {k:<11} {v}" for k, v in KINDS.items())
    parser = argparse.ArgumentParser(
        prog="scripts/ax12 plot",
        description="Plot a figure from a run of the real firmware ELF (ax12-lab).",
        epilog="KIND:\n" + kinds, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("kind", metavar="KIND", choices=sorted(KINDS), help="one of: " + ", ".join(KINDS))
    parser.add_argument("--out", required=True, metavar="FILE.png", help="the PNG to write")
    parser.add_argument("--lab", default=os.environ.get("AX12_LAB", "ax12-lab"), help="the ax12-lab program")
    parser.add_argument("--csv", metavar="FILE", help="also keep the CSV the figure was drawn from")
    parser.add_argument("--profile", choices=["ax12", "ax12a"], default="ax12", help="behaviour profile (default ax12)")
    # scripts/ax12 checks the arguments before it builds ax12-lab: a usage error comes at once.
    parser.add_argument("--check-arguments", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.check_arguments:
        return

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    text = run_lab(args.lab, args.kind, ["--profile", args.profile])
    if args.csv:
        with open(args.csv, "w") as f:
            f.write(text)
    data = rows(text)
    if not data:
        sys.exit(f"ax12 plot: {args.kind}: no data")
    fig = PLOTTERS[args.kind](plt, data)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(args.out)


if __name__ == "__main__":
    main()
