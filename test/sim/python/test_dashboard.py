# SPDX-License-Identifier: GPL-3.0-or-later
"""The live dashboard (`ax12-emu serve --dashboard`, docs/dashboard.md) in a real headless
Chromium driven by Selenium, on a 3-servo bus that DynamixelSDK drives through the pty at the
same time. Screenshots are kept in $AX12_ARTIFACT_DIR (build/test-artifacts)."""
import os
import re
import shutil
import socket
import threading
import time
import urllib.request

import dynamixel_sdk as sdk
import pytest
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select

import ax12_headroom as H
import ax12_table as T

ARTIFACTS = os.environ.get("AX12_ARTIFACT_DIR") or os.path.join(os.getcwd(), "test-artifacts")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(predicate, timeout_s, what):
    deadline = time.monotonic() + timeout_s
    last = None
    while time.monotonic() < deadline:
        try:
            last = predicate()
        except Exception as e:  # an element rebuilt under us: look again
            last = e
        if last and not isinstance(last, Exception):
            return last
        time.sleep(0.1)
    pytest.fail("timed out waiting for %s (last: %r)" % (what, last))


def open_port(device):
    port = sdk.PortHandler(device)
    assert port.openPort()
    assert port.setBaudRate(1000000)
    return port, sdk.PacketHandler(1.0)


@pytest.fixture
def downloads(tmp_path):
    folder = tmp_path / "downloads"
    folder.mkdir()
    return folder


def headless_chromium(*args, prefs=None):
    """Debian's Chromium, headless through its driver (scripts/setup --tests), with these
    command-line arguments and preferences."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    driver_path = shutil.which("chromedriver") or "/usr/bin/chromedriver"
    if not chromium or not os.path.exists(driver_path):
        pytest.fail("Chromium and its driver are missing: scripts/setup --tests installs them")
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage") + args:
        options.add_argument(arg)
    if prefs:
        options.add_experimental_option("prefs", prefs)
    return webdriver.Chrome(service=Service(driver_path), options=options)


@pytest.fixture
def browser(downloads):
    driver = headless_chromium("--disable-gpu", "--window-size=1400,1900",
                               prefs={"download.default_directory": str(downloads),
                                      "download.prompt_for_download": False})
    yield driver
    driver.quit()


def retried(call, *args):
    """An SDK exchange, again when it timed out: on a loaded machine the kernel sometimes holds a
    pty write back for longer than the SDK waits (with or without the dashboard)."""
    deadline = time.monotonic() + 2.0  # the pty has been seen to hold a write for 140 ms
    while True:
        try:
            outcome = call(*args)
        except IndexError:  # DynamixelSDK 4.1.0 takes a late status of that ID as the reply
            outcome = (None, sdk.COMM_RX_CORRUPT, 0)
        if outcome[-2] == sdk.COMM_SUCCESS or time.monotonic() > deadline:
            return outcome


def cell(driver, slot, column):
    """The text of a column (0 = slot) of a servo's row in the servo list."""
    return driver.find_element(By.ID, "servo-row-%d" % slot).find_elements(By.TAG_NAME, "td")[column].text


def shot(driver, name):
    os.makedirs(ARTIFACTS, exist_ok=True)
    driver.save_screenshot(os.path.join(ARTIFACTS, "dashboard-%s.png" % name))


def message(driver):
    return driver.find_element(By.ID, "message").text


def refused_supply(driver, typed, said):
    """The world form's supply given `typed` and applied: the page says `said`, the servo's
    supply stays 9.6 V."""
    supply = driver.find_element(By.ID, "world-supply")
    supply.clear()
    supply.send_keys(typed)
    driver.find_element(By.ID, "world-apply").click()
    wait_for(lambda: message(driver) == said, 5, "the message for %r" % typed)
    assert "supply 9.6 V" in driver.find_element(By.ID, "world-now").text


def monitor_rows(driver):
    """The bus monitor's rows as lists of cell texts."""
    return driver.execute_script(
        "return [...document.querySelectorAll('#monitor tbody tr')].map(r => [...r.cells].map(c => c.textContent));")


def stat(busy, idle, cpus=2):
    """A /proc/stat text: the totals line, then one line per CPU."""
    user, system = busy // 2, busy - busy // 2
    lines = ["cpu  %d 0 %d %d 0 0 0 0 0 0" % (user, system, idle)]
    lines += ["cpu%d 1 0 1 1 0 0 0 0 0 0" % i for i in range(cpus)]
    return "\n".join(lines + ["intr 1 2 3", "ctxt 4"]) + "\n"


def test_idle_cores_come_from_proc_stat():
    assert H.cpu_times("cpu  10 2 3 40 5 1 1 0 7 0\ncpu0 1 1 1 1\n") == (17, 45)
    readings = iter([stat(100, 100), stat(150, 250), stat(350, 250)])
    idle = H.IdleCores(lambda: next(readings))
    assert idle.reading() is None             # the first reading has nothing to compare with
    assert idle.reading() == pytest.approx(1.5)  # 150 of 200 jiffies idle, on 2 CPUs
    assert idle.reading() == 0.0              # every jiffy busy
    assert H.IdleCores(lambda: "not proc stat").reading() is None

    def missing():
        raise OSError("no /proc")
    assert H.IdleCores(missing).reading() is None


def test_the_update_rate_steps_back_while_the_machine_has_no_core_to_spare():
    rate = H.UpdateRate()
    assert rate.hz == H.BUSY_HZ  # a page opened on a busy machine does not cost it the full rate
    assert [rate.update(1.5) for _ in range(H.UP_AFTER_S)][-1] == H.FULL_HZ
    assert rate.update(0.1) == H.FULL_HZ     # one busy second is not enough
    assert rate.update(0.5) == H.FULL_HZ     # and the run starts again
    assert [rate.update(0.1) for _ in range(H.DOWN_AFTER_S)][-1] == H.BUSY_HZ
    assert rate.update(0.4) == H.BUSY_HZ     # the full rate's own cost must fit in what is idle
    assert [rate.update(None) for _ in range(H.UP_AFTER_S)][-1] == H.FULL_HZ  # no /proc/stat: full


def updates_drawn(driver):
    """The page's header: updates drawn in the last second, and whether the server slowed them."""
    text = driver.find_element(By.ID, "rate").text
    return int(text.split()[0]) if text[:1].isdigit() else 0, "no CPU core to spare" in text


class MachineLoad:
    """A /proc/stat of two cores whose counters advance every 0.2 s as an idle or a busy machine
    would (AX12_PROC_STAT, python/ax12_headroom.py): the page's rate follows the load given here,
    whatever else runs beside the test."""

    def __init__(self, path):
        self.path, self.busy, self.jiffies = path, False, [0, 0]
        self.stopped = threading.Event()
        self.write()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def write(self):
        busy, idle = self.jiffies
        text = "cpu  %d 0 0 %d 0 0 0 0 0 0\ncpu0 0 0 0 0 0 0 0 0 0 0\ncpu1 0 0 0 0 0 0 0 0 0 0\n" % (busy, idle)
        with open(self.path + ".new", "w") as f:
            f.write(text)
        os.replace(self.path + ".new", self.path)

    def run(self):
        while not self.stopped.wait(0.2):
            self.jiffies[0 if self.busy else 1] += 40  # two cores' 20 jiffies in 0.2 s
            self.write()

    def stop(self):
        self.stopped.set()
        self.thread.join()


def test_the_dashboard_shows_edits_and_changes_the_world_of_a_live_bus(emulator, browser, downloads, tmp_path,
                                                                     monkeypatch):
    load = MachineLoad(str(tmp_path / "stat"))
    monkeypatch.setenv("AX12_PROC_STAT", load.path)
    port_number = free_port()
    emu = emulator("--realtime", "--ids", "1-3", "--state-dir", str(tmp_path), "--dashboard", str(port_number))
    url = "http://127.0.0.1:%d/" % port_number
    port, handler = open_port(emu.device)
    try:
        browser.get(url)
        wait_for(lambda: browser.find_element(By.ID, "connection").text == "live", 15, "the page to go live")
        wait_for(lambda: cell(browser, 3, 1) == "3", 10, "servo 3 in the list")

        # Live: 20 updates a second while the machine has a core to spare; 2 while every core is
        # busy (the load MachineLoad gives), and 20 again once a core is free.
        def full_rate():
            # the server's rate as the page holds it, and the page drawing faster than the busy
            # rate allows (how many frames a loaded machine's browser draws is not the server's)
            drawn, slowed = updates_drawn(browser)
            return browser.execute_script("return state.rate && state.rate.hz") == H.FULL_HZ \
                and drawn > H.BUSY_HZ + 1 and not slowed
        wait_for(full_rate, 15, "20 updates a second")
        load.busy = True
        wait_for(lambda: updates_drawn(browser)[1], 15, "the page slowed down on a busy machine")
        time.sleep(1.5)
        assert updates_drawn(browser)[0] <= H.BUSY_HZ + 1
        load.busy = False
        wait_for(full_rate, 15, "20 updates a second again")

        # A goal written through DynamixelSDK moves the servo on the page.
        assert retried(handler.write1ByteTxRx, port, 2, T.TORQUE_ENABLE, 1) == (sdk.COMM_SUCCESS, 0)
        assert retried(handler.write2ByteTxRx, port, 2, T.GOAL_POSITION, 800) == (sdk.COMM_SUCCESS, 0)
        wait_for(lambda: cell(browser, 2, 2) == "800", 5, "Goal Position 800 on the page")
        wait_for(lambda: abs(int(cell(browser, 2, 3)) - 800) <= 10, 10, "Present Position near 800 on the page")
        shot(browser, "1-goal")

        # The header tells real time: the scheduling, the lag, the delays of the SDK's requests.
        timing = browser.find_element(By.ID, "timing").text
        assert re.match(r"real time, (SCHED_FIFO 10|ordinary scheduling): lag [\d.]+ ms \(worst [\d.]+\); "
                        r"client to bus [\d.]+ / [\d.]+ / [\d.]+ ms, replies late [\d.]+ / [\d.]+ / [\d.]+ ms", timing), timing

        # An edit in the page's control table, read back through the SDK.
        browser.find_element(By.ID, "servo-row-3").click()
        wait_for(lambda: browser.find_element(By.ID, "selected-name").text.startswith("3"), 5, "servo 3 selected")
        field = browser.find_element(By.ID, "item-%d" % T.RETURN_DELAY_TIME)
        field.send_keys("100")
        browser.find_element(By.ID, "write-%d" % T.RETURN_DELAY_TIME).click()
        wait_for(lambda: "Return Delay Time = 100 written" in message(browser), 5, "the write's answer")
        value, result, error = retried(handler.read1ByteTxRx, port, 3, T.RETURN_DELAY_TIME)
        assert (value, result, error) == (100, sdk.COMM_SUCCESS, 0)
        wait_for(lambda: browser.find_element(By.ID, "value-%d" % T.RETURN_DELAY_TIME).text == "100", 5,
                 "the table showing 100")

        # Bad values: a clear message, and the servo keeps its ID.
        field = browser.find_element(By.ID, "item-%d" % T.ID)
        field.send_keys("300")
        browser.find_element(By.ID, "write-%d" % T.ID).click()
        wait_for(lambda: "holds 0..255" in message(browser), 5, "the message for 300")
        field.clear()
        field.send_keys("254")
        browser.find_element(By.ID, "write-%d" % T.ID).click()
        wait_for(lambda: "refused by the servo: Range" in message(browser), 5, "the servo's Range Error")
        field.clear()
        field.send_keys("abc")
        browser.find_element(By.ID, "write-%d" % T.ID).click()
        wait_for(lambda: "whole number" in message(browser), 5, "the message for abc")
        assert retried(handler.ping, port, 3)[1:] == (sdk.COMM_SUCCESS, 0)
        shot(browser, "2-table")

        # The bus monitor: the page's WRITE as the control master's instruction and the servo's
        # answer, the SDK's packets as the client's; filtered by ID; exported as CSV.
        # The monitor fills while it is on screen (docs/dashboard.md): scroll to it as a user would.
        browser.execute_script("document.getElementById('monitor-scroll').scrollIntoView()")

        def edit_on_the_monitor():
            rows = monitor_rows(browser)
            writes = [r for r in rows if r[1] == "control" and r[2] == "3" and r[3] == "WRITE"]
            return writes and writes[0][4] == "05 64" and any(r[1] == "client" and r[3] == "PING" for r in rows)
        wait_for(edit_on_the_monitor, 5, "the page's WRITE and the SDK's PING on the bus monitor")
        assert any(r[1] == "servo-3" and r[3] == "Range" for r in monitor_rows(browser))
        browser.find_element(By.ID, "monitor-filter").send_keys("2")
        wait_for(lambda: monitor_rows(browser) and all(r[2] == "2" for r in monitor_rows(browser)), 5,
                 "only ID 2 on the filtered monitor")
        browser.find_element(By.ID, "monitor-export").click()
        exported = wait_for(lambda: [f for f in downloads.iterdir() if f.suffix == ".csv"], 10, "the CSV download")
        lines = exported[0].read_text().splitlines()
        assert lines[0] == "time_us,end_us,sender,kind,id,code,code_name,params,checksum_ok,collision,line,raw"
        assert len(lines) > 2 and all(line.split(",")[4] == "2" for line in lines[1:])
        assert any(",client,instruction,2,0x03,WRITE," in line for line in lines)
        browser.find_element(By.ID, "monitor-filter").clear()
        browser.execute_script("document.getElementById('monitor-filter').dispatchEvent(new Event('input'))")
        browser.execute_script("window.scrollTo(0, 0)")

        # A bad world from the page changes nothing.
        browser.find_element(By.ID, "servo-row-2").click()
        wait_for(lambda: browser.find_element(By.ID, "selected-name").text.startswith("2"), 5, "servo 2 selected")
        refused_supply(browser, "99", "World not changed: supply V 99 is outside 0.1..30")
        supply = browser.find_element(By.ID, "world-supply")

        # A load far above the stall torque, raised from the page: Overload on the page and in
        # the servo's status packets (docs/policy.md "Alarms": within about 1 s of stalling).
        supply.clear()
        supply.send_keys("9.6")
        Select(browser.find_element(By.ID, "world-load-kind")).select_by_value("torque")
        torque = browser.find_element(By.ID, "world-load-torque")
        torque.clear()
        torque.send_keys("-3")
        browser.find_element(By.ID, "world-apply").click()
        wait_for(lambda: "world changed" in message(browser), 5, "the world change's answer")
        wait_for(lambda: "Overload" in browser.find_element(By.ID, "alarms-2").text, 10, "Overload on the page")
        _, result, error = retried(handler.read1ByteTxRx, port, 2, T.ID)
        assert result == sdk.COMM_SUCCESS and error & T.ERR_OVERLOAD
        time.sleep(1.0)  # ten seconds of charts behind the screenshot are not needed: one is
        shot(browser, "3-overload")
    finally:
        port.closePort()
        load.stop()

    # Closing the page changes nothing: the bus and the dashboard go on.
    browser.get("about:blank")
    port, handler = open_port(emu.device)
    try:
        assert retried(handler.ping, port, 1)[1:] == (sdk.COMM_SUCCESS, 0)
        with urllib.request.urlopen(url, timeout=5) as page:
            assert page.status == 200
    finally:
        port.closePort()
    assert emu.proc.poll() is None


# Run before the page's own scripts: the WebSocket's messages reach the page no earlier than
# this many seconds after it loads.
HOLD_MESSAGES_S = """
    const Real = window.WebSocket, loaded = performance.now(), holdMs = %f * 1000;
    window.WebSocket = class extends Real {
      set onmessage(handler) {
        super.onmessage = (m) => {
          const wait = holdMs - (performance.now() - loaded);
          if (wait > 0) setTimeout(() => handler(m), wait); else handler(m);
        };
      }
    };"""


def rate_samples(driver, seconds):
    """(text, class) of the page's rate in the header, every 50 ms for this long."""
    return driver.execute_async_script("""
        const done = arguments[arguments.length - 1], samples = [], seconds = arguments[0];
        const timer = setInterval(() => {
          const rate = document.getElementById('rate');
          samples.push([rate.textContent, rate.className]);
          if (samples.length >= seconds * 20) { clearInterval(timer); done(samples); }
        }, 50);""", seconds)


def series_pixels(driver):
    """How many pixels of the overview chart's canvas are drawn in each servo's own colour."""
    return driver.execute_script("""
        const plot = state.overview, probe = document.createElement('canvas').getContext('2d');
        const rgb = (css) => { probe.fillStyle = css; probe.fillRect(0, 0, 1, 1);
                               return [...probe.getImageData(0, 0, 1, 1).data.slice(0, 3)]; };
        const colours = plot.series.slice(1).map((s) => rgb(s._stroke ?? s.stroke()));
        const ctx = plot.ctx, pixels = ctx.getImageData(0, 0, ctx.canvas.width, ctx.canvas.height).data;
        const counts = colours.map(() => 0);
        for (let p = 0; p < pixels.length; p += 4) {
          colours.forEach((c, i) => {
            if (Math.abs(pixels[p] - c[0]) + Math.abs(pixels[p + 1] - c[1]) + Math.abs(pixels[p + 2] - c[2]) < 12
                && pixels[p + 3] > 200) counts[i]++;
          });
        }
        return counts;""")


def test_a_new_page_shows_every_servo_its_icon_and_its_own_words(emulator, browser, tmp_path):
    """A fresh 3-servo bus, every servo at 512: the overview shows each servo's colour where
    their lines lie on one another; the page has an icon; its rate reads no '0 updates/s' and
    no red while the machine's load is still being measured; a world value that is not a number
    is refused in the page's words, naming the field and the text typed."""
    port_number = free_port()
    emulator("--realtime", "--ids", "1-3", "--state-dir", str(tmp_path), "--dashboard", str(port_number))
    url = "http://127.0.0.1:%d/" % port_number
    # The page's first 4 s without a message from the server (held back, as a slow start or a
    # busy machine holds them): no rate is shown until frames are drawn.
    browser.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": HOLD_MESSAGES_S % 4.0})
    browser.get(url)
    samples = rate_samples(browser, 5.5)
    assert not [s for s in samples if s[0].startswith("0 ")], samples
    assert not [s for s in samples if "measured" in s[0] and s[1] == "bad"], samples
    assert any("updates/s" in s[0] for s in samples), samples
    # The server's rate before it has read the machine's load: said, not in red.
    text, colour = browser.execute_script("""
        state.rate = { hz: 2, full_hz: 20, idle_cores: null }; state.frames = 2; showRate();
        return [document.getElementById('rate').textContent, document.getElementById('rate').className];""")
    assert "while the machine's load is measured" in text and colour != "bad", (text, colour)

    icon = browser.execute_script("const l = document.querySelector('link[rel=icon]'); return l && l.href;")
    assert icon, "the page names an icon"
    with urllib.request.urlopen(icon, timeout=5) as answer:
        assert answer.status == 200 and answer.headers["Content-Type"].startswith("image/svg+xml")
        assert b"<svg" in answer.read()

    wait_for(lambda: cell(browser, 3, 3) == "512", 10, "servo 3 at 512")
    time.sleep(1.0)  # a second of points on the overview
    counts = wait_for(lambda: all(series_pixels(browser)) and series_pixels(browser), 5,
                      "every servo's colour on the overview")
    assert len(counts) == 3, counts
    shot(browser, "4-overview")

    refused_supply(browser, "abc", "World not changed: supply V 'abc' is not a number (0.1..30)")


# The world form's fields (web/dashboard/index.html: data-min, data-max) as world options: the
# option, and how a field's value makes the option's text with the others at a value inside.
FORM_FIELDS = {
    "world-supply": ("supply", "{}"),
    "world-ambient": ("ambient", "{}"),
    "world-load-torque": ("load-torque", "{}"),
    "world-spring-k": ("load-spring", "{},150"),
    "world-spring-rest": ("load-spring", "1,{}"),
    "world-arm-kg": ("load-arm", "{},0.1,150"),
    "world-arm-m": ("load-arm", "0.1,{},150"),
    "world-arm-deg": ("load-arm", "0.1,0.1,{}"),
}


def test_the_world_forms_ranges_are_the_emulators(emulator, tmp_path):
    """The page checks the world's values against the ranges its fields carry; the emulator
    takes each field's bounds and refuses just past them, so page and emulator say the same."""
    import re
    from html.parser import HTMLParser

    import ax12_control

    fields = {}

    class Fields(HTMLParser):
        def handle_starttag(self, tag, attrs):
            a = dict(attrs)
            if tag == "input" and a.get("id", "").startswith("world-") and "data-min" in a:
                fields[a["id"]] = (float(a["data-min"]), float(a["data-max"]))
    Fields().feed(open(os.path.join(os.path.dirname(__file__), "..", "..", "..", "web", "dashboard",
                                    "index.html")).read())
    assert set(fields) == set(FORM_FIELDS), sorted(fields)
    emulator("--fast", "--state-dir", str(tmp_path), "--control", str(tmp_path / "c.sock"))
    with ax12_control.Control(str(tmp_path / "c.sock")) as control:
        for field, (low, high) in sorted(fields.items()):
            option, text = FORM_FIELDS[field]
            for value in (low, high):
                control.request("world", id=1, set={option: text.format(value)})
            step = 0.01 if re.search(r"(kg|-m)$", field) else 0.1
            for value in (low - step, high + step):
                with pytest.raises(ax12_control.ControlError):
                    control.request("world", id=1, set={option: text.format(round(value, 3))})
