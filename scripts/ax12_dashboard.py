#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""The live dashboard of `scripts/ax12 serve --dashboard [HOST:]PORT` (docs/dashboard.md): a web
page (web/dashboard, charts by uPlot and the robot's 3D view by three.js, both from npm,
installed by scripts/setup: nothing is fetched at run time) fed through a WebSocket from the emulator's control socket.

The server holds three connections to the control socket, subscribed only while a page is
open: every servo at the update rate (ax12_headroom: 20 times a second while the machine has a
core to spare, 2 while it has none) and the bus monitor's packets; the servos the pages show,
20 times a second with their control tables 5 times a second; and one for the pages' requests.
A page gets every servo at the update rate (its list and overview) and, in the same messages,
the points of the servo it shows (its charts and control table): in each of them while that
servo's section is on screen, once a second otherwise. A page's edit of a control-table item becomes a
Protocol 1.0 WRITE that the emulator puts on the bus (so it obeys every rule a client's write
obeys; the servo's status packet is the answer); a world change goes to the emulator as it is.
The bus monitor's packets come in batches (one message per batch, every 50 ms at most), sent
to a page only while its monitor is on screen, so a busy bus costs the page and this server
little. Bad input gets a message and changes nothing; a page that stops reading is dropped, and
nothing a page does stops the bus.

With a robot (`serve --robot`), every telemetry message carries its pose ("robot": every
body's position and orientation, docs/robot.md "The robot on the control socket"), GET
/api/robot gives what a 3D view needs to draw it (bodies, geoms, meshes, its world), and a
page's {"type": "robot", "set": {...}} changes its world (a payload, a push, gravity) as
`scripts/ax12 world` does.

Started by ax12-emu with --control PATH --listen HOST:PORT; prints one line
`listening http://HOST:PORT/` on stdout once it serves, then logs only to stderr. It exits
when the emulator closes the control socket.
"""
import argparse
import asyncio
import collections
import json
import os
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "python"))

from aiohttp import WSMsgType, web  # noqa: E402

import ax12_headroom  # noqa: E402

WEB = os.path.join(REPO, "web", "dashboard")
UPLOT = os.path.join(WEB, "node_modules", "uplot", "dist")
THREE = os.path.join(WEB, "node_modules", "three")  # its build/ and its addons (examples/jsm/)
TELEMETRY_HZ = 20         # the selected servo's charts
TABLE_HZ = 5              # the shown servo's control table
POINTS_PERIOD_OFF_S = 1.0  # a page's chart points while its charts are off screen (else every whole event)
POINTS_KEPT = 100         # points of a batch at most (5 s)
PACKET_BATCHES_KEPT = 200  # for a page opened later: 10 s of batches (50 ms apart at most)
PAGE_QUEUE = 2000         # lines waiting for a page before it is dropped
SEND_TIMEOUT_S = 5.0


def log(message):
    print("ax12 dashboard: %s" % message, file=sys.stderr, flush=True)


class Emulator:
    """The control socket: requests on one connection (one at a time), events on two others.
    Events are subscribed to only while a page is open; the whole ones are relayed as the text
    they came in (parsed only when a page's request needs the latest telemetry), the shown
    servos' ones gathered into each page's batches: the server costs the bus little."""

    def __init__(self, path):
        self.path = path
        self.lock = asyncio.Lock()
        self.reader = self.writer = self.events_writer = None
        self.latest_line = None       # the last telemetry event, as text
        self.latest_parsed = (None, None)
        self.batches = collections.deque(maxlen=PACKET_BATCHES_KEPT)  # packet batches, as text
        self.pages = {}               # open WebSocket -> its queue of lines to send
        self.selected = {}            # open WebSocket -> the slot it shows
        self.monitoring = {}          # open WebSocket -> whether its bus monitor is on screen
        self.shown_on_screen = {}     # open WebSocket -> whether its servo's charts are on screen
        self.points = {}              # open WebSocket -> its servo's points not sent yet
        self.rate = ax12_headroom.UpdateRate()  # every servo's updates a second, while pages are open

    async def connect(self):
        self.reader, self.writer = await asyncio.open_unix_connection(self.path, limit=1 << 24)
        events_reader, self.events_writer = await asyncio.open_unix_connection(self.path, limit=1 << 24)
        charts_reader, self.charts_writer = await asyncio.open_unix_connection(self.path, limit=1 << 24)
        return events_reader, charts_reader

    async def subscribe(self):
        """While any page is open: every servo at the update rate and the packets on one
        connection; the servos the pages show, TELEMETRY_HZ times a second with their control
        tables TABLE_HZ times a second, on another. Nothing while no page is open."""
        on = bool(self.pages)
        self.events_writer.write(json.dumps({"op": "subscribe", "telemetry_hz": self.rate.hz if on else 0,
                                             "packets": on}).encode() + b"\n")
        shown = sorted({slot for slot in self.selected.values() if isinstance(slot, int)})
        self.charts_writer.write(json.dumps({"op": "subscribe", "telemetry_hz": TELEMETRY_HZ if on and shown else 0,
                                             "table_hz": TABLE_HZ, "servos": shown,
                                             "robot": False}).encode() + b"\n")  # poses: in the whole events
        await self.events_writer.drain()
        await self.charts_writer.drain()

    @property
    def latest(self):
        line, parsed = self.latest_parsed
        if line is not self.latest_line:
            parsed = json.loads(self.latest_line) if self.latest_line else None
            self.latest_parsed = (self.latest_line, parsed)
        return parsed

    async def request(self, message):
        async with self.lock:
            self.writer.write(json.dumps(message).encode() + b"\n")
            await self.writer.drain()
            while True:
                line = await asyncio.wait_for(self.reader.readline(), SEND_TIMEOUT_S)
                if not line:
                    raise ConnectionError("the emulator closed the control socket")
                reply = json.loads(line)
                if "event" not in reply:
                    return reply

    async def pump_charts(self, charts_reader):
        """The shown servos' telemetry: each page's own servo's points are kept for its next
        whole event (pump_events), but sent at once for a servo just selected."""
        while True:
            line = await charts_reader.readline()
            if not line:
                return
            if not line.startswith(b'{"event":"telemetry"'):
                continue
            event = json.loads(line)
            by_slot = {s["slot"]: s for s in event["servos"]}
            now = time.monotonic()
            for ws in list(self.pages):
                slot = self.selected.get(ws)
                servo = by_slot.get(slot)
                if servo is None:
                    continue
                batch = self.points.setdefault(ws, {"slot": slot, "points": [], "sent": 0.0})
                if batch["slot"] != slot:
                    batch.update(slot=slot, points=[], sent=0.0)
                servo["time_us"] = event["time_us"]
                batch["points"].append(servo)
                del batch["points"][:-POINTS_KEPT]
                if not batch["sent"]:
                    self.relay(ws, '{"event":"points",%s}' % self.take_points(ws, now)[1:-1])

    def take_points(self, ws, now):
        """A page's batch of points as JSON text, or None: every whole event while its servo's
        section is on screen, POINTS_PERIOD_OFF_S apart otherwise."""
        batch = self.points.get(ws)
        if not batch or not batch["points"]:
            return None
        if not self.shown_on_screen.get(ws) and batch["sent"] and now - batch["sent"] < POINTS_PERIOD_OFF_S:
            return None
        text = json.dumps({"slot": batch["slot"], "points": batch["points"]}, separators=(",", ":"))
        batch.update(points=[], sent=now)
        return text

    async def pump_events(self, events_reader):
        """Relays the whole telemetry (with the page's own points in it: one message, one
        wake-up of the page, one frame) and the packets to every page until the emulator goes
        away."""
        while True:
            line = await events_reader.readline()
            if not line:
                return
            text = line.decode().strip()
            if text.startswith('{"event":"telemetry"'):
                self.latest_line = text
                now = time.monotonic()
                for ws in list(self.pages):
                    points = self.take_points(ws, now)
                    self.relay(ws, text if points is None else text[:-1] + ',"points":' + points + "}")
            elif text.startswith('{"event":"packets"'):
                self.batches.append(text)
                for ws in list(self.pages):
                    if self.monitoring.get(ws, True):
                        self.relay(ws, text)

    def rate_event(self, idle_cores):
        return json.dumps({"event": "rate", "hz": self.rate.hz, "full_hz": ax12_headroom.FULL_HZ,
                           "idle_cores": None if idle_cores is None else round(idle_cores, 2)})

    async def pace(self, idle=None):
        """Once a second while pages are open: the machine's idle CPU sets the update rate
        (ax12_headroom); a change is subscribed to; every page is told the rate and the reading.
        The machine is read even while no page is open, so a page's first second has a reading."""
        idle = idle or ax12_headroom.IdleCores()
        while True:
            await asyncio.sleep(1.0)
            idle_cores = idle.reading()
            if not self.pages:
                continue
            before = self.rate.hz
            if self.rate.update(idle_cores) != before:
                log("%d updates a second (idle CPU: %s cores)" % (
                    self.rate.hz, "unknown" if idle_cores is None else "%.2f" % idle_cores))
                await self.subscribe()
            for ws in list(self.pages):
                self.relay(ws, self.rate_event(idle_cores))

    def relay(self, ws, text):
        queue = self.pages.get(ws)
        if queue is None:
            return
        try:
            queue.put_nowait(text)
        except asyncio.QueueFull:  # a page that does not keep up is dropped
            self.pages.pop(ws, None)
            asyncio.ensure_future(ws.close())
            asyncio.ensure_future(self.subscribe())



def servo_of(emu, slot):
    """The servo of the latest telemetry with that slot (its --ids entry), or None."""
    if emu.latest is None:
        return None
    for s in emu.latest["servos"]:
        if s["slot"] == slot:
            return s
    return None


def error_names(error):
    import ax12_table
    return [name.replace("_", " ").title() for bit, name in sorted(ax12_table.ERROR_BITS.items()) if error & bit]


async def page_write(emu, msg):
    """A control-table edit: checked for what a packet can carry, then a WRITE on the bus."""
    import ax12_packets
    import ax12_table
    slot, addr, value = msg.get("slot"), msg.get("addr"), msg.get("value")
    servo = servo_of(emu, slot) if isinstance(slot, int) else None
    if servo is None or "id" not in servo:
        return False, "no servo %r on this bus" % (slot,)
    item = ax12_table.BY_ADDR.get(addr) if isinstance(addr, int) else None
    if item is None:
        return False, "no control-table item at address %r" % (addr,)
    if isinstance(value, str) and value.strip().lstrip("-").isdigit():
        value = int(value.strip())
    if not isinstance(value, int) or isinstance(value, bool):
        return False, "%s: the value must be a whole number" % item.title
    if not 0 <= value < 256 ** item.size:
        return False, "%s: a %d-byte item holds 0..%d" % (item.title, item.size, 256 ** item.size - 1)
    params = [addr] + [(value >> (8 * i)) & 0xFF for i in range(item.size)]
    packet = ax12_packets.instruction_packet(servo["id"], ax12_table.INST_WRITE, params)
    reply = await emu.request({"op": "send", "bytes": packet.hex(" ").upper()})
    if not reply.get("ok"):
        return False, reply.get("error", "refused")
    answer = ax12_packets.parse(bytes.fromhex(reply["reply"])) if reply["reply"] else None
    sent = " ".join("%02X" % b for b in packet)
    if answer is None:
        return True, "sent %s; no status packet came back (Status Return Level, or no servo with ID %d)" % (
            sent, servo["id"])
    events = answer.code & ax12_table.ERR_EVENTS
    if events:
        return False, "%s = %d refused by the servo: %s (nothing changed); sent %s, answer %s" % (
            item.title, value, ", ".join(error_names(events)), sent, reply["reply"])
    note = " (conditions held: %s)" % ", ".join(error_names(answer.code)) if answer.code else ""
    return True, "%s = %d written%s; sent %s, answer %s" % (item.title, value, note, sent, reply["reply"])


async def page_world(emu, msg):
    slot, changes = msg.get("slot"), msg.get("set")
    if not isinstance(slot, int) or servo_of(emu, slot) is None:
        return False, "no servo %r on this bus" % (slot,)
    if not isinstance(changes, dict) or not changes:
        return False, "nothing to change"
    reply = await emu.request({"op": "world", "id": slot, "set": changes})
    if not reply.get("ok"):
        return False, reply.get("error", "refused")
    return True, "servo %d's world changed: %s" % (slot, ", ".join("%s %s" % kv for kv in changes.items()))


async def page_robot(emu, msg):
    """A change of the robot's world: {"payload": ..., "push": ..., "gravity": ...} as the
    control socket's "robot" request takes it (checked whole by the emulator)."""
    changes = msg.get("set")
    if not isinstance(changes, dict) or not changes:
        return False, "nothing to change (payload, push, gravity)"
    reply = await emu.request({"op": "robot", "set": changes})
    if not reply.get("ok"):
        return False, reply.get("error", "refused")
    return True, "the robot's world changed: %s" % ", ".join("%s %s" % (k, json.dumps(v)) for k, v in changes.items())


async def send_queued(ws, queue):
    while True:
        text = await queue.get()
        await ws.send_str(text)


async def answer(emu, ws, msg):
    kind = msg.get("type") if isinstance(msg, dict) else None
    if kind == "select":
        emu.selected[ws] = msg.get("slot")
        await emu.subscribe()
        return None
    if kind == "monitor":  # the page's monitor came on screen (the last seconds first) or left it
        on = bool(msg.get("on"))
        if on and not emu.monitoring.get(ws, True):
            for batch in emu.batches:
                emu.relay(ws, batch)
        emu.monitoring[ws] = on
        return None
    if kind == "shown":  # the page's servo section (charts, control table) came on screen or left it
        emu.shown_on_screen[ws] = bool(msg.get("on"))
        return None
    try:
        if kind == "write":
            return await page_write(emu, msg)
        if kind == "world":
            return await page_world(emu, msg)
        if kind == "robot":
            return await page_robot(emu, msg)
        return False, "unknown request (write, world or robot)"
    except (asyncio.TimeoutError, ConnectionError) as e:
        return False, "the emulator did not answer: %s" % (e or "timeout")


async def websocket(request):
    emu = request.app["emu"]
    ws = web.WebSocketResponse(heartbeat=10.0)
    await ws.prepare(request)
    queue = asyncio.Queue(PAGE_QUEUE)
    emu.pages[ws] = queue
    emu.monitoring[ws] = False  # until the page says its monitor is on screen
    if len(emu.pages) == 1:
        await emu.subscribe()
    emu.relay(ws, emu.rate_event(None))
    sender = asyncio.ensure_future(send_queued(ws, queue))
    try:
        async for frame in ws:
            if frame.type != WSMsgType.TEXT:
                continue
            try:
                msg = json.loads(frame.data)
            except ValueError:
                msg = None
            answered = await answer(emu, ws, msg)
            if answered is None:
                continue
            ok, text = answered
            result = {"event": "result", "req": msg.get("req") if isinstance(msg, dict) else None, "ok": ok,
                      "message": text}
            try:
                queue.put_nowait(json.dumps(result))
            except asyncio.QueueFull:
                break
    finally:
        emu.pages.pop(ws, None)
        emu.selected.pop(ws, None)
        emu.monitoring.pop(ws, None)
        emu.shown_on_screen.pop(ws, None)
        emu.points.pop(ws, None)
        sender.cancel()
        if not emu.pages:
            emu.rate = ax12_headroom.UpdateRate()  # the next page starts again from the busy rate
            await emu.subscribe()
    return ws


async def items(request):
    import ax12_table
    return web.json_response([item._asdict() for item in ax12_table.ITEMS])


async def robot(request):
    """The robot's description (docs/robot.md): {"robot": {...}}, or {"robot": null} without one."""
    emu = request.app["emu"]
    try:
        reply = await emu.request({"op": "robot"})
    except (asyncio.TimeoutError, ConnectionError) as e:
        return web.json_response({"robot": None, "error": "the emulator did not answer: %s" % (e or "timeout")},
                                 status=503)
    return web.json_response({"robot": reply.get("robot") if reply.get("ok") else None})


async def index(request):
    return web.FileResponse(os.path.join(WEB, "index.html"))


def parse_listen(text):
    host, _, port = text.rpartition(":")
    if not port.isdigit() or not 0 < int(port) < 65536:
        raise argparse.ArgumentTypeError("[HOST:]PORT, e.g. 8080 or 127.0.0.1:8080")
    return host or "127.0.0.1", int(port)


async def serve(args):
    emu = Emulator(args.control)
    deadline = time.monotonic() + 10.0
    while True:
        try:
            events_reader, charts_reader = await emu.connect()
            break
        except OSError as e:
            if time.monotonic() > deadline:
                log("cannot reach the emulator's control socket %s: %s" % (args.control, e))
                return 1
            await asyncio.sleep(0.1)
    app = web.Application()
    app["emu"] = emu
    app.router.add_get("/", index)
    app.router.add_get("/ws", websocket)
    app.router.add_get("/api/items", items)
    app.router.add_get("/api/robot", robot)
    app.router.add_static("/static/", WEB)
    app.router.add_static("/uplot/", UPLOT)
    app.router.add_static("/three/build/", os.path.join(THREE, "build"))
    app.router.add_static("/three/addons/", os.path.join(THREE, "examples", "jsm"))
    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    host, port = args.listen
    try:
        await web.TCPSite(runner, host, port).start()
    except OSError as e:
        log("cannot listen on %s:%d: %s" % (host, port, e.strerror or e))
        return 1
    print("listening http://%s:%d/" % (host if ":" not in host else "[%s]" % host, port), flush=True)
    charts = asyncio.ensure_future(emu.pump_charts(charts_reader))
    pace = asyncio.ensure_future(emu.pace())
    await emu.pump_events(events_reader)  # until the emulator closes the socket
    charts.cancel()
    pace.cancel()
    for ws in list(emu.pages):
        await ws.close()
    await runner.cleanup()
    return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--control", required=True, help="the emulator's control socket")
    parser.add_argument("--listen", type=parse_listen, default=("127.0.0.1", 8080), help="[HOST:]PORT")
    parser.add_argument("--build", default=os.path.join(REPO, "build"), help="the build folder (ax12_table.py)")
    args = parser.parse_args()
    import ax12_build
    ax12_build.ensure(args.build)
    for asset in (os.path.join(UPLOT, "uPlot.iife.min.js"), os.path.join(THREE, "build", "three.module.js")):
        if not os.path.exists(asset):
            log("%s is missing: run scripts/setup (it installs uPlot and three.js with npm)" % asset)
            return 1
    try:
        return asyncio.run(serve(args))
    except KeyboardInterrupt:
        return 0


if __name__ == "__main__":
    sys.exit(main())
