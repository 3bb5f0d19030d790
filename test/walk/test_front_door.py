# SPDX-License-Identifier: GPL-3.0-or-later
"""scripts/ax12's own checks before it builds anything: a bad argument of `plot` stops with the
usage at once, without a build; the help of `plot`, `world` and `flash-isp` needs none either.
(What each command builds, from a clone with nothing built: test_newcomer_walk.py.)"""
import subprocess
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
AX12 = REPO / "scripts" / "ax12"


def front_door(*args):
    started = time.monotonic()
    proc = subprocess.run([str(AX12), *args], capture_output=True, text=True, timeout=120)
    return proc, time.monotonic() - started


def test_plot_with_a_bad_kind_stops_with_its_usage_before_any_build(tmp_path):
    proc, _ = front_door("plot", "bogus", "--out", str(tmp_path / "x.png"))
    assert proc.returncode == 2, proc.stderr
    assert "invalid choice: 'bogus'" in proc.stderr and proc.stderr.startswith("usage: scripts/ax12 plot"), \
        proc.stderr
    assert "building" not in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
    assert not (tmp_path / "x.png").exists()


def test_plot_without_its_output_stops_before_any_build():
    proc, _ = front_door("plot", "step")
    assert proc.returncode == 2 and "--out" in proc.stderr and "building" not in proc.stderr, proc.stderr


def test_help_builds_nothing():
    for args in (("plot", "--help"), ("world", "--help")):
        proc, _ = front_door(*args)
        assert proc.returncode == 0 and proc.stdout.startswith("usage: scripts/ax12 " + args[0]), proc.stdout
        assert "building" not in proc.stderr, proc.stderr
