# SPDX-License-Identifier: GPL-3.0-or-later
"""A newcomer's walk: the front door's commands in the order README.md leads to them, each in a
clone where nothing was built before the walk, each preparing what it needs itself
(scripts/ax12: setup, then its own build targets). Every command must exit 0 with no Python
traceback:

  1. scripts/ax12 serve, then Ctrl-C (SIGINT)
  2. scripts/ax12 serve --ids 1-3 --dashboard PORT: the page loads in headless Chromium and
     goes live with the three servos;
  3. scripts/ax12 world, while it runs;
  4. scripts/ax12 plot step --out FILE.png;
  5. scripts/ax12 serve --link L --log-bus FILE.csv with DynamixelSDK's ping and a READ, then
     scripts/ax12 replay FILE.csv --port L against a new serve: SAME;
  6. scripts/ax12 conform --port L --only matrix against it: PASS;
  7. scripts/ax12 build, then scripts/ax12 flash-isp --programmer usbasp --mcu atmega328p
     --dry-run;
  8. scripts/ax12 serve --ids 1-2 --mcu atmega328p and scripts/ax12 flash of servo 2 with
     the ax12a application.

AX12_WALK_REPO names the clone (scripts/test: the CI's own clean clone before its build, or a
clone of HEAD in a temporary folder with `scripts/test --walk`). The Python environment and
the dashboard's npm assets may be shared with the repository the clone came from (scripts/setup
then finds them in place); the build may not: a command that builds too little fails here.
The servos' state goes to a folder of the walk's own (XDG_STATE_HOME).
"""
import os
import signal
import shutil
import socket
import subprocess
import tempfile
import threading
import time
from pathlib import Path

import pytest

REPO = Path(os.environ.get("AX12_WALK_REPO", "")).resolve()
AX12 = REPO / "scripts" / "ax12"
# The first command builds the emulator and the firmware: minutes on a busy 2-core machine.
FIRST_BUILD_S = 1500
COMMAND_S = 600


@pytest.fixture(scope="module")
def walk_dir():
    if not os.environ.get("AX12_WALK_REPO") or not AX12.exists():
        pytest.fail("AX12_WALK_REPO must name a clone of the repository (scripts/test sets it)")
    folder = Path(tempfile.mkdtemp(prefix="ax12-walk-"))
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="module")
def env(walk_dir):
    environment = dict(os.environ)
    environment["XDG_STATE_HOME"] = str(walk_dir / "state")
    environment.pop("AX12_CMAKE_ARGS", None)
    return environment


def no_traceback(what, *texts):
    for text in texts:
        assert "Traceback (most recent call last)" not in text, "%s: %s" % (what, text)


def run(env, *args, timeout=COMMAND_S):
    """One command to its end: its CompletedProcess, after the checks every step makes."""
    proc = subprocess.run([str(AX12), *args], cwd=REPO, env=env, capture_output=True, text=True, timeout=timeout)
    what = "scripts/ax12 " + " ".join(args)
    no_traceback(what, proc.stdout, proc.stderr)
    assert proc.returncode == 0, "%s: exit %d\n%s\n%s" % (what, proc.returncode, proc.stdout, proc.stderr[-4000:])
    return proc


class Serve:
    """scripts/ax12 serve ARGS, up to its `ready:` line."""

    def __init__(self, env, folder, *args, timeout=COMMAND_S):
        self.what = "scripts/ax12 serve " + " ".join(args)
        self.err_path = folder / ("serve-%d.err" % time.monotonic_ns())
        self.err = open(self.err_path, "w")
        self.proc = subprocess.Popen([str(AX12), "serve", *args], cwd=REPO, env=env, stdout=subprocess.PIPE,
                                     stderr=self.err, text=True)
        too_long = threading.Timer(timeout, self.proc.kill)
        too_long.start()
        line = self.proc.stdout.readline()  # the build first, then `ready: /dev/pts/N`
        too_long.cancel()
        if not line.startswith("ready: "):
            self.proc.kill()
            self.proc.wait()
            pytest.fail("%s did not get ready: %r\n%s" % (self.what, line, self.stderr()[-4000:]))
        self.device = line.split(" ", 1)[1].strip()

    def stderr(self):
        if not self.err.closed:
            self.err.flush()
        return self.err_path.read_text()

    def interrupt(self):
        """Ctrl-C: exit 0, no traceback."""
        self.proc.send_signal(signal.SIGINT)
        code = self.proc.wait(timeout=60)
        self.err.close()
        no_traceback(self.what, self.stderr())
        assert code == 0, "%s: exit %d after SIGINT\n%s" % (self.what, code, self.stderr()[-4000:])


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def sdk_ping_and_read(device):
    """What a newcomer's first program does: DynamixelSDK's ping (a PING and a READ) and a READ
    of Present Position, each tried again when a busy machine's pty held it past the SDK's
    timeout."""
    from dynamixel_sdk import COMM_SUCCESS, PacketHandler, PortHandler
    port, handler = PortHandler(device), PacketHandler(1.0)
    assert port.openPort() and port.setBaudRate(1000000)
    try:
        for call, args in ((handler.ping, (port, 1)), (handler.read2ByteTxRx, (port, 1, 36))):
            for _ in range(5):
                result = call(*args)
                if result[1] == COMM_SUCCESS:
                    break
            assert result[1] == COMM_SUCCESS and result[2] == 0, (call.__name__, result)
    finally:
        port.closePort()


def page_goes_live(url):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    driver_path = shutil.which("chromedriver") or "/usr/bin/chromedriver"
    assert chromium and os.path.exists(driver_path), "Chromium and its driver: scripts/setup --tests"
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(driver_path), options=options)
    try:
        driver.get(url)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            live = driver.find_element(By.ID, "connection").text == "live"
            rows = driver.find_elements(By.CSS_SELECTOR, "#servos tbody tr")
            if live and len(rows) == 3:
                return
            time.sleep(0.2)
        pytest.fail("the dashboard at %s did not go live with 3 servos" % url)
    finally:
        driver.quit()


def test_a_newcomer_walks_from_a_fresh_clone_through_every_command(walk_dir, env):
    assert not (REPO / "build" / "CMakeCache.txt").exists(), "the walk starts with nothing built"
    timings = []

    def step(name, started):
        timings.append("%s %.0f s" % (name, time.monotonic() - started))

    started = time.monotonic()
    Serve(env, walk_dir, timeout=FIRST_BUILD_S).interrupt()
    step("serve", started)

    started = time.monotonic()
    port = free_port()
    serve = Serve(env, walk_dir, "--ids", "1-3", "--dashboard", str(port))
    page_goes_live("http://127.0.0.1:%d/" % port)
    world = run(env, "world")
    for slot in (1, 2, 3):
        assert "servo %d:" % slot in world.stdout, world.stdout
    serve.interrupt()
    step("dashboard, world", started)

    started = time.monotonic()
    png = walk_dir / "step.png"
    run(env, "plot", "step", "--out", str(png))
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    step("plot", started)

    started = time.monotonic()
    link, recording = walk_dir / "ax12", walk_dir / "recording.csv"
    serve = Serve(env, walk_dir, "--link", str(link), "--log-bus", str(recording))
    sdk_ping_and_read(str(link))
    serve.interrupt()
    serve = Serve(env, walk_dir, "--link", str(link))
    for attempt in range(3):  # a busy machine's pty may hold an answer past the replay's timeout
        replay = subprocess.run([str(AX12), "replay", str(recording), "--port", str(link)], cwd=REPO, env=env,
                                capture_output=True, text=True, timeout=COMMAND_S)
        no_traceback("scripts/ax12 replay", replay.stdout, replay.stderr)
        if replay.returncode == 0 or ": missing:" not in replay.stdout:
            break
    assert replay.returncode == 0 and "result: SAME" in replay.stdout, replay.stdout + replay.stderr
    step("log-bus, replay", started)

    started = time.monotonic()
    for attempt in range(2):  # a busy machine's pty may hold a reply past the tool's timeout
        conform = subprocess.run([str(AX12), "conform", "--port", str(link), "--only", "matrix"], cwd=REPO,
                                 env=env, capture_output=True, text=True, timeout=COMMAND_S)
        no_traceback("scripts/ax12 conform", conform.stdout, conform.stderr)
        if conform.returncode == 0:
            break
    assert conform.returncode == 0 and "result: PASS" in conform.stdout, conform.stdout + conform.stderr
    serve.interrupt()
    step("conform", started)

    started = time.monotonic()
    run(env, "build")
    isp = run(env, "flash-isp", "--programmer", "usbasp", "--mcu", "atmega328p", "--dry-run")
    assert "avrdude" in isp.stdout and "-p m328p" in isp.stdout, isp.stdout
    step("build, flash-isp", started)

    started = time.monotonic()
    link328 = walk_dir / "ax12-328p"
    serve = Serve(env, walk_dir, "--ids", "1-2", "--mcu", "atmega328p", "--link", str(link328),
                  "--state-dir", str(walk_dir / "state-328p"))
    flashed = run(env, "flash", "--port", str(link328), "--id", "2",
                  str(REPO / "build" / "firmware" / "ax12-ax12a-atmega328p.hex"))
    assert "the application runs: Model Number 12" in flashed.stdout, flashed.stdout
    serve.interrupt()
    step("flash", started)
    print("newcomer's walk: " + ", ".join(timings))
