// SPDX-License-Identifier: GPL-3.0-or-later
// The live dashboard's page: telemetry from the WebSocket into the servo list, uPlot charts of
// the selected servo (the last HISTORY_S seconds), its control table (editable: each edit is a
// WRITE the emulator puts on the bus), its world, the bus monitor, and with a robot its 3D view
// (robot_view.js) and its world.
"use strict";

const HISTORY_S = 15;
const MONITOR_ROWS = 300;       // rows on the page (the export takes every packet kept)
const MONITOR_KEPT = 10000;     // packets kept
const MONITOR_PERIOD_MS = 500;  // the monitor is redrawn at most this often
const RENDER_PERIOD_MS = 40;    // the page is redrawn at most this often (whole events: 20 or 5 a second)
const state = {
  ws: null, items: [], servos: [], selected: null, history: new Map(), charts: [], profile: "ax12",
  packets: [], nextReq: 1, overview: null, overviewSlots: [], overviewHistory: null,
  streamSlot: null, // the servo whose points come in batches (20 a second): the selected one
  table: null,      // the selected servo's control table, as its last batch of points had it
  rate: null,       // the server's update rate: { hz, full_hz, idle_cores }
  frames: 0,        // frames drawn since the last second began (shown as updates a second)
  robot: null,      // GET /api/robot's description (docs/robot.md), or null without a robot
  robotView: null,  // its 3D view, once three.js is loaded (none without WebGL)
  gravityHeldUntil: 0, // the gravity box, just clicked, is not reset by telemetry older than the change
};

const $ = (id) => document.getElementById(id);
const signed10 = (v) => (v & 0x3ff) * (v & 0x400 ? -1 : 1); // speed and load: bit 10 is CW
const ERROR_NAMES = [[0x01, "Voltage"], [0x02, "Angle Limit"], [0x04, "Overheating"], [0x08, "Range"],
  [0x10, "Checksum"], [0x20, "Overload"], [0x40, "Instruction"]];
const errorNames = (bits) => ERROR_NAMES.filter(([bit]) => bits & bit).map(([, name]) => name);

function say(text, ok) {
  const m = $("message");
  m.textContent = text;
  m.className = ok ? "good" : "bad";
}

// ---- servos and history -------------------------------------------------------------------

function record(time_s, s) {
  let h = state.history.get(s.slot);
  if (!h) {
    h = { t: [], goal: [], present: [], speed: [], load: [], duty: [], current: [], winding: [], kase: [],
      supply: [] };
    state.history.set(s.slot, h);
  }
  if (h.t.length && time_s <= h.t[h.t.length - 1]) return; // a point the history has already
  if (s.slot === state.selected) state.chartsDirty = true;
  h.t.push(time_s);
  h.goal.push(s.goal_position ?? null);
  h.present.push(s.present_position ?? null);
  h.speed.push(s.present_speed === undefined ? null : signed10(s.present_speed));
  h.load.push(s.present_load === undefined ? null : signed10(s.present_load));
  h.duty.push(s.duty);
  h.current.push(s.motor_current_a ?? null);
  h.winding.push(s.winding_c ?? null);
  h.kase.push(s.case_c ?? null);
  h.supply.push(s.supply_v ?? null);
  while (h.t.length && h.t[0] < time_s - HISTORY_S) {
    for (const k of Object.keys(h)) h[k].shift();
  }
}

function cell(text, cls) {
  const td = document.createElement("td");
  td.textContent = text;
  if (cls) td.className = cls;
  return td;
}

function alarmsText(s) {
  const names = errorNames(s.conditions ?? 0);
  return names.length ? names.join(", ") : "–";
}

// Rows are made once per servo and their cells updated in place (a click is never lost to a
// row rebuilt under the pointer).
function servoRow(slot) {
  let tr = document.getElementById("servo-row-" + slot);
  if (!tr) {
    tr = document.createElement("tr");
    tr.id = "servo-row-" + slot;
    for (let i = 0; i < 15; i++) tr.append(cell(""));
    tr.cells[14].id = "alarms-" + slot;
    tr.addEventListener("click", () => select(slot));
    $("servos").tBodies[0].append(tr);
  }
  return tr;
}

function renderServos() {
  if (!listVisible) return; // drawn again when it comes on screen
  const fmt = (v, d) => (v === undefined || v === null ? "–" : Number(v).toFixed(d));
  for (const s of state.servos) {
    const tr = servoRow(s.slot);
    const rowClass = s.slot === state.selected ? "selected" : "";
    if (tr.className !== rowClass) tr.className = rowClass;
    const values = [s.slot, s.id ?? "–", s.goal_position ?? "–", s.present_position ?? "–",
      s.present_speed === undefined ? "–" : signed10(s.present_speed),
      s.present_load === undefined ? "–" : signed10(s.present_load), fmt(s.duty, 2), fmt(s.motor_current_a, 2),
      fmt(s.winding_c, 1), fmt(s.case_c, 1), fmt(s.supply_v, 2), s.led ? "on" : "off", s.torque_enable ? "on" : "off",
      s.moving ?? "–", alarmsText(s)];
    values.forEach((v, i) => { if (tr.cells[i].textContent !== String(v)) tr.cells[i].textContent = v; });
    const alarmClass = s.conditions ? "alarm text" : "text";
    if (tr.cells[14].className !== alarmClass) tr.cells[14].className = alarmClass;
  }
}

// ---- charts -------------------------------------------------------------------------------

const CHARTS = [
  { title: "Position (counts)", series: [["Goal", "goal", "#888"], ["Present", "present", "#06c"]] },
  { title: "Speed and load (signed, CCW +)", series: [["Present Speed", "speed", "#06c"], ["Present Load", "load", "#c60"]] },
  { title: "H-bridge", series: [["duty", "duty", "#06c"], ["motor current A", "current", "#c00"]] },
  { title: "Heat (°C)", series: [["winding", "winding", "#c00"], ["case", "kase", "#c80"]] },
  { title: "Supply at the connector (V)", series: [["supply", "supply", "#070"]] },
];

function buildCharts() {
  for (const c of state.charts) c.plot.destroy();
  state.charts = [];
  $("charts").replaceChildren();
  for (const def of CHARTS) {
    const holder = document.createElement("div");
    $("charts").append(holder);
    // No cursor and a legend without live values: redrawn 5 times a second, a chart costs
    // its canvas only.
    const opts = {
      title: def.title, width: 400, height: 170,
      scales: { x: { time: false } },
      axes: [{ label: "s (simulated)" }, {}],
      cursor: { show: false },
      legend: { live: false },
      series: [{ label: "t", show: false }].concat(def.series.map(([label, , stroke]) => ({ label, stroke, width: 1.5, points: { show: false } }))),
    };
    const plot = new uPlot(opts, [[], ...def.series.map(() => [])], holder);
    state.charts.push({ def, plot, holder });
    screenWatch.observe(holder);
  }
}

// Present Position of every servo in one chart (one series per servo). Each line is dashed so
// that the servos' dashes take turns along it: where servos hold the same position (a new bus:
// all at 512) their lines lie on one another and still show every servo's colour.
const OVERVIEW_DASH_PX = 6;
function overviewDash(i, count) {
  const dash = Math.max(2, Math.round(OVERVIEW_DASH_PX * 3 / Math.max(count, 3)));
  return count < 2 ? [] : [0, i * dash, dash, (count - 1 - i) * dash];
}

function buildOverview(slots) {
  state.overviewSlots = slots;
  state.overviewHistory = { t: [], present: slots.map(() => []) };
  const series = [{ label: "t" }].concat(slots.map((slot, i) => ({
    label: String(slot), stroke: `hsl(${(i * 137) % 360}, 65%, 45%)`, width: 1.6, points: { show: false },
    dash: overviewDash(i, slots.length), cap: "butt",
  })));
  const opts = {
    title: "Present Position, every servo (counts)", width: 820, height: 170,
    scales: { x: { time: false } }, axes: [{ label: "s (simulated)" }, {}], series,
    cursor: { show: false }, legend: { show: slots.length <= 18, live: false },
  };
  state.overview = new uPlot(opts, [[], ...slots.map(() => [])], $("overview"));
  screenWatch.observe($("overview"));
}

// The overview's own history: every servo's Present Position at each whole event.
function recordOverview(event) {
  if (state.overview === null) buildOverview(event.servos.map((s) => s.slot));
  const o = state.overviewHistory;
  state.overviewDirty = true; // redrawn at the next frame, not at every event
  o.t.push(event.time_us / 1e6);
  state.overviewSlots.forEach((slot, i) => {
    const s = event.servos.find((x) => x.slot === slot);
    o.present[i].push(s && s.present_position !== undefined ? s.present_position : null);
  });
  while (o.t.length && o.t[0] < o.t[o.t.length - 1] - HISTORY_S) {
    o.t.shift();
    for (const p of o.present) p.shift();
  }
}

function drawOverview() {
  if (state.overview && state.overviewDirty) {
    state.overviewDirty = false;
    state.overview.setData([state.overviewHistory.t, ...state.overviewHistory.present]);
  }
}

// Charts off screen are not drawn (their data are kept): a page scrolled to its list or
// monitor costs no chart drawing.
const onScreen = new Set();
const screenWatch = new IntersectionObserver((entries) => {
  for (const e of entries) {
    if (e.isIntersecting) onScreen.add(e.target); else onScreen.delete(e.target);
  }
  state.overviewDirty = state.chartsDirty = true;
  drawCharts();
});

// Whatever the events changed is drawn in one frame, RENDER_PERIOD_MS apart at least (a frame
// costs more than what it draws, in software): the list, the header, the control table and the
// charts on screen together.
function scheduleRender() {
  if (state.renderPending) return;
  state.renderPending = true;
  const wait = Math.max(0, (state.lastRender ?? -Infinity) + RENDER_PERIOD_MS - performance.now());
  setTimeout(() => requestAnimationFrame(render), wait);
}

function render() {
  state.renderPending = false;
  state.lastRender = performance.now();
  if (state.rateTimer === undefined) state.rateTimer = setInterval(showRate, 1000);
  state.frames++;
  const event = state.lastEvent;
  if (event && state.eventDirty) {
    state.eventDirty = false;
    setText($("profile"), `${event.servos.length} servo(s), profile ${event.profile}, ${event.mcu}`);
    setText($("clock"), `t = ${(event.time_us / 1e6).toFixed(2)} s`);
    if (event.timing) showTiming(event.timing);
    renderServos();
    const s = event.servos.find((x) => x.slot === state.selected);
    if (s) setText($("world-now"), describeWorld(s.world));
    if (event.robot && state.robot) showRobotPose(event.robot);
  }
  if (state.tableDirty) {
    state.tableDirty = false;
    updateTable(state.table);
  }
  drawCharts();
}

function drawCharts() {
  if (onScreen.has($("overview"))) drawOverview();
  const h = state.history.get(state.selected);
  if (!h || !state.chartsDirty) return;
  state.chartsDirty = false;
  for (const { def, plot, holder } of state.charts) {
    if (onScreen.has(holder)) plot.setData([h.t, ...def.series.map(([, key]) => h[key])]);
  }
}

// ---- control table ------------------------------------------------------------------------

function access(item) {
  return state.profile === "ax12a" ? item.access_ax12a : item.access_ax12;
}

function itemValue(table, item) {
  return item.size === 2 ? table[item.addr] | (table[item.addr + 1] << 8) : table[item.addr];
}

function buildTable() {
  const body = $("control-table").tBodies[0];
  body.replaceChildren();
  for (const item of state.items) {
    const tr = document.createElement("tr");
    const value = cell("–");
    value.id = "value-" + item.addr;
    const range = access(item) === "RW" ? item.min + ".." + item.max : "";
    tr.append(cell(item.addr), cell(item.title, "text"), value, cell(access(item)), cell(range));
    const td = document.createElement("td");
    if (access(item) === "RW") {
      const input = document.createElement("input");
      input.id = "item-" + item.addr;
      input.type = "text";
      const button = document.createElement("button");
      button.id = "write-" + item.addr;
      button.type = "button";
      button.textContent = "Write";
      button.addEventListener("click", () => writeItem(item, input.value));
      input.addEventListener("keydown", (e) => { if (e.key === "Enter") writeItem(item, input.value); });
      td.append(input, button);
    }
    tr.append(td);
    body.append(tr);
  }
}

function updateTable(table) {
  if (!table || !shownVisible) return;
  for (const item of state.items) {
    const td = $("value-" + item.addr);
    const text = String(itemValue(table, item));
    if (td && td.textContent !== text) td.textContent = text;
  }
}

function request(message) {
  if (!state.ws || state.ws.readyState !== WebSocket.OPEN) {
    say("not connected to the emulator", false);
    return;
  }
  message.req = state.nextReq++;
  state.ws.send(JSON.stringify(message));
}

function writeItem(item, text) {
  const trimmed = String(text).trim();
  if (!/^\d+$/.test(trimmed)) {
    say(item.title + ": the value must be a whole number", false);
    return;
  }
  request({ type: "write", slot: state.selected, addr: item.addr, value: Number(trimmed) });
}

// ---- world --------------------------------------------------------------------------------

function showLoadFields() {
  const kind = $("world-load-kind").value;
  for (const label of document.querySelectorAll("#world-form .load")) {
    label.style.display = label.classList.contains(kind) ? "block" : "none";
  }
}

function fillWorld(s) {
  const w = s.world;
  $("world-supply").value = w.supply;
  $("world-ambient").value = w.ambient;
  $("world-load-kind").value = w.load;
  if (w.load === "torque") $("world-load-torque").value = w.load_torque_nm;
  if (w.load === "spring") { $("world-spring-k").value = w.spring_nm_rad; $("world-spring-rest").value = w.rest_deg; }
  if (w.load === "arm") {
    $("world-arm-kg").value = w.mass_kg; $("world-arm-m").value = w.arm_m; $("world-arm-deg").value = w.horizontal_deg;
  }
  showLoadFields();
}

function describeWorld(w) {
  const loads = {
    none: "no load", torque: `constant torque ${w.load_torque_nm} N m`,
    spring: `spring ${w.spring_nm_rad} N m/rad toward ${Number(w.rest_deg).toFixed(0)}°`,
    arm: `${w.mass_kg} kg on ${w.arm_m} m`,
  };
  return `supply ${w.supply} V, ambient ${w.ambient} °C, ${loads[w.load]}`;
}

// A world field's number, or null after saying, in the page's words, what is wrong with it:
// its label, the text as typed and the range its data-min / data-max give (those of `serve`'s
// options, docs/dashboard.md).
function worldNumber(id) {
  const input = $(id);
  const text = input.value.trim();
  const range = `${input.dataset.min}..${input.dataset.max}`;
  const value = Number(text);
  if (text === "" || !Number.isFinite(value)) {
    say(`World not changed: ${input.dataset.name} ${text === "" ? "is empty" : `'${text}' is not a number`} (${range})`, false);
    return null;
  }
  if (value < Number(input.dataset.min) || value > Number(input.dataset.max)) {
    say(`World not changed: ${input.dataset.name} ${text} is outside ${range}`, false);
    return null;
  }
  return text;
}

function applyWorld(event) {
  event.preventDefault();
  const kind = $("world-load-kind").value;
  const fields = { none: [], torque: ["world-load-torque"], spring: ["world-spring-k", "world-spring-rest"],
    arm: ["world-arm-kg", "world-arm-m", "world-arm-deg"] }[kind];
  const values = ["world-supply", "world-ambient", ...fields].map(worldNumber);
  if (values.includes(null)) return;
  const [supply, ambient, ...load] = values;
  const set = { supply, ambient };
  if (kind === "none") set["load-none"] = true;
  else set["load-" + kind] = load.join(",");
  request({ type: "world", slot: state.selected, set });
}

// ---- robot --------------------------------------------------------------------------------

// The robot's section: its 3D view (three.js is loaded only with a robot, and the page works
// without WebGL, the view replaced by a line saying why) and the forms that change its world
// as `scripts/ax12 world` does (docs/robot.md "The robot's world while it runs").
async function startRobot(robot) {
  state.robot = robot;
  $("robot").hidden = false;
  $("robot-name").textContent = robot.name;
  const bodies = robot.bodies.slice(1).map((b) => b.name);
  const preferred = defaultBody(robot);
  for (const id of ["robot-payload-body", "robot-push-body"]) {
    $(id).replaceChildren(...bodies.map((name) => new Option(name, name, false, name === preferred)));
  }
  $("robot-payload-form").addEventListener("submit", applyPayload);
  $("robot-push-form").addEventListener("submit", applyPush);
  $("robot-gravity").addEventListener("change", () => {
    state.gravityHeldUntil = performance.now() + 1500;
    request({ type: "robot", set: { gravity: $("robot-gravity").checked } });
  });
  showRobotPose(robot.pose);
  try {
    const { RobotView } = await import("/static/robot_view.js");
    state.robotView = new RobotView($("robot-view"), robot, select);
  } catch (e) {
    $("robot-view").textContent = `No 3D view in this browser (${e.message || e}); the rest of the page works.`;
    $("robot-view").className = "bad";
    return;
  }
  state.robotView.highlight(state.selected);
  $("robot-home").addEventListener("click", () => state.robotView.resetView());
}

// The body the forms offer first: a floating robot's base (a hexapod's body), else the end of
// its longest chain (a pendulum's tip, an arm's gripper).
function defaultBody(robot) {
  const floating = robot.joints.find((j) => j.type === "free");
  if (floating) return robot.bodies[floating.body].name;
  const depth = (i) => (i <= 0 ? 0 : 1 + depth(robot.bodies[i].parent));
  let deepest = 1;
  robot.bodies.forEach((_, i) => { if (depth(i) >= depth(deepest)) deepest = i; });
  return robot.bodies[deepest]?.name;
}

function showRobotPose(pose) {
  if (state.robotView) state.robotView.setPose(pose);
  const w = pose.world;
  const parts = [`physics t = ${pose.time_s.toFixed(2)} s`, w.gravity ? "gravity on" : "gravity off"];
  if (w.payloads.length) parts.push("payloads: " + w.payloads.map((p) => `${p.body} ${p.kg} kg`).join(", "));
  for (const p of w.pushes) parts.push(`pushing ${p.body} with (${p.force_n.join(", ")}) N, ${p.seconds_left.toFixed(2)} s left`);
  setText($("robot-now"), parts.join("; "));
  if (performance.now() > state.gravityHeldUntil && $("robot-gravity").checked !== w.gravity) {
    $("robot-gravity").checked = w.gravity;
  }
}

// A field's number, or null with a message (the emulator checks the ranges, the page only
// that a number was given).
function numberOf(id, what) {
  const text = $(id).value.trim();
  const value = Number(text);
  if (text === "" || !Number.isFinite(value)) {
    say(`${what}: give a number`, false);
    return null;
  }
  return value;
}

function applyPayload(event) {
  event.preventDefault();
  const kg = numberOf("robot-payload-kg", "payload kg");
  if (kg === null) return;
  request({ type: "robot", set: { payload: { body: $("robot-payload-body").value, kg } } });
}

function applyPush(event) {
  event.preventDefault();
  const force = [["robot-push-x", "push x"], ["robot-push-y", "push y"], ["robot-push-z", "push z"]].map(([id, what]) => numberOf(id, what));
  const seconds = numberOf("robot-push-s", "push seconds");
  if (force.includes(null) || seconds === null) return;
  request({ type: "robot", set: { push: { body: $("robot-push-body").value, force_n: force, seconds } } });
}

// ---- bus monitor --------------------------------------------------------------------------

// The filter: IDs separated by spaces or commas; packets without an ID (garbage) only when
// no filter is set.
function packetMatches(p) {
  const filter = $("monitor-filter").value.trim();
  if (!filter) return true;
  return filter.split(/[ ,]+/).some((id) => id !== "" && Number(id) === p.id);
}

const escapeHtml = (text) => String(text).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);

function packetRowHtml(p) {
  let what = p.kind; // garbage, protocol2
  if (p.kind === "instruction") what = p.instruction_name;
  if (p.kind === "status") what = errorNames(p.error).join(", ") || "status, no error";
  const framed = p.kind === "instruction" || p.kind === "status";
  const checksum = p.checksum_ok === false ? '<td class="bad">bad</td>' : `<td>${p.checksum_ok ? "good" : "–"}</td>`;
  return `<tr${p.collision ? ' class="collision"' : ""}><td>${Number(p.time_us).toFixed(1)}</td>` +
    `<td class="text">${escapeHtml(p.sender)}</td><td>${framed ? p.id : "–"}</td><td class="text">${escapeHtml(what)}</td>` +
    `<td class="text">${escapeHtml(framed ? p.params : p.raw)}</td>${checksum}</tr>`;
}

// Packets arrive in batches (up to thousands a second on a busy bus): the table is redrawn at
// most every MONITOR_PERIOD_MS, with the last MONITOR_ROWS matching packets.
// The monitor is drawn only while it is on screen (the packets are kept all the same).
let monitorTimer = null;
let monitorVisible = false;
// The servo list and the selected servo's section (charts, control table) are updated only
// while on screen; the server sends the section's points more often while it is.
let listVisible = false;
let shownVisible = false;
function sendShownState() {
  if (state.ws && state.ws.readyState === WebSocket.OPEN) state.ws.send(JSON.stringify({ type: "shown", on: shownVisible }));
}
function sendMonitorState() {
  if (state.ws && state.ws.readyState === WebSocket.OPEN) state.ws.send(JSON.stringify({ type: "monitor", on: monitorVisible }));
}
function addPackets(list) {
  for (const p of list) state.packets.push(p);
  if (state.packets.length > MONITOR_KEPT) state.packets.splice(0, state.packets.length - MONITOR_KEPT);
  if (monitorVisible && !$("monitor-pause").checked && monitorTimer === null) {
    monitorTimer = setTimeout(() => { monitorTimer = null; renderMonitor(); }, MONITOR_PERIOD_MS);
  }
}

function renderMonitor() {
  const shown = [];
  for (let i = state.packets.length - 1; i >= 0 && shown.length < MONITOR_ROWS; i--) {
    if (packetMatches(state.packets[i])) shown.push(state.packets[i]);
  }
  shown.reverse();
  $("monitor").tBodies[0].innerHTML = shown.map(packetRowHtml).join("");
  $("monitor-count").textContent = `${shown.length} shown, ${state.packets.length} kept`;
  const scroll = $("monitor-scroll");
  scroll.scrollTop = scroll.scrollHeight;
}

function exportCsv() {
  // The columns of `serve --log-bus` (docs/emulator.md), so `ax12 replay` reads an export.
  const rows = [["time_us", "end_us", "sender", "kind", "id", "code", "code_name", "params", "checksum_ok",
    "collision", "line", "raw"]];
  const hex2 = (v) => "0x" + v.toString(16).toUpperCase().padStart(2, "0");
  for (const p of state.packets.filter(packetMatches)) {
    const framed = p.kind === "instruction" || p.kind === "status";
    let name = "";
    if (p.kind === "instruction") name = p.instruction_name;
    if (p.kind === "status") name = ERROR_NAMES.filter(([bit]) => p.error & bit).map(([, n]) => n.toUpperCase().replace(" ", "_")).join("|") || "NONE";
    rows.push([p.time_us.toFixed(3), p.end_us.toFixed(3), p.sender, p.kind, framed ? p.id : "", framed ? hex2(p.code) : "",
      name, framed ? p.params : "", framed ? (p.checksum_ok ? 1 : 0) : "", p.collision ? 1 : 0, "", p.raw]);
  }
  const quote = (v) => (/[",\n]/.test(String(v)) ? `"${String(v).replaceAll('"', '""')}"` : String(v));
  const text = rows.map((r) => r.map(quote).join(",")).join("\n") + "\n";
  const link = document.createElement("a");
  link.href = URL.createObjectURL(new Blob([text], { type: "text/csv" }));
  link.download = "ax12-bus.csv";
  link.click();
}

// ---- wiring -------------------------------------------------------------------------------

function select(slot) {
  state.selected = slot;
  state.table = null; // until the new servo's first points
  state.chartsDirty = true;
  if (state.ws && state.ws.readyState === WebSocket.OPEN) state.ws.send(JSON.stringify({ type: "select", slot }));
  const s = state.servos.find((x) => x.slot === slot);
  $("selected-name").textContent = s ? `${slot} (ID ${s.id ?? "?"})` : "–";
  buildTable();
  if (s) fillWorld(s);
  if (state.robotView) state.robotView.highlight(slot);
  renderServos();
  drawCharts();
}

// Events come whole (every servo, without control tables) 5 times a second: the list, the
// overview and the charts of the servos not shown take them. The servo shown comes 20 points a
// second with its control table 5 times a second, in batches carried by the whole events (each
// one while its section is on screen, once a second otherwise; on their own for a servo just
// selected): its charts and its table take them. One frame per whole event.
function onTelemetry(event) {
  state.profile = event.profile;
  if (event.points) takePoints(event.points);
  const t = event.time_us / 1e6;
  for (const s of event.servos) {
    if (s.slot !== state.streamSlot || s.slot !== state.selected) record(t, s);
  }
  recordOverview(event);
  state.servos = event.servos;
  state.lastEvent = event;
  state.eventDirty = true;
  if (state.selected === null && event.servos.length) select(event.servos[0].slot);
  scheduleRender();
}

function takePoints(batch) {
  if (batch.slot !== state.selected) return; // points of the servo shown before
  state.streamSlot = batch.slot;
  for (const p of batch.points) {
    record(p.time_us / 1e6, p);
    if (p.table) state.table = p.table;
  }
  state.tableDirty = true;
}

function onPoints(batch) {
  takePoints(batch);
  if (shownVisible || onScreen.size) scheduleRender(); // else nothing of them is on screen
}

// Updates a second as drawn (frames in the last second), and why fewer when the server has
// slowed the whole updates down because the machine has no CPU core to spare (docs/dashboard.md).
// Counted from the first frame on, once a second: a page still connecting shows no rate. Red
// only when the server has measured a machine with no core to spare.
function showRate() {
  const drawn = `${state.frames} updates/s`;
  state.frames = 0;
  const r = state.rate;
  const busy = r && r.hz < r.full_hz;
  const measuring = r && r.idle_cores === null;
  const why = measuring ? "while the machine's load is measured" : "no CPU core to spare, the bus comes first";
  setText($("rate"), busy ? `${drawn} (${r.hz}/s: ${why})` : drawn);
  $("rate").className = busy && !measuring ? "bad" : "";
}

// Real time as the emulator keeps it (docs/dashboard.md): its scheduling policy, its lag now
// and at worst, and how long a client's bytes took to reach the bus (p50 / p99 / max) beside how
// late the replies reached the client, so a late reply can be told from a late request.
const LATE_MS = 20; // a lag past this shows in red: DynamixelSDK's timeout is about 34 ms
function showTiming(t) {
  const ms = (x) => x.toFixed(x < 10 ? 2 : 0);
  const el = $("timing");
  if (!t.realtime) {
    setText(el, "fast (not real time)");
    el.className = "";
    return;
  }
  const policy = { held: t.policy.split(" (")[0], dropped: "ordinary scheduling (late: policy dropped)",
                   "not allowed": "ordinary scheduling" }[t.policy_state] || t.policy;
  const b = t.to_bus_delay, c = t.to_client_late;
  setText(el, `real time, ${policy}: lag ${ms(t.lag_ms)} ms (worst ${ms(t.worst_lag_ms)}); ` +
    `client to bus ${ms(b.p50_ms)} / ${ms(b.p99_ms)} / ${ms(b.max_ms)} ms, ` +
    `replies late ${ms(c.p50_ms)} / ${ms(c.p99_ms)} / ${ms(c.max_ms)} ms (p50 / p99 / max)`);
  el.title = t.policy;
  el.className = t.policy_state !== "held" || t.worst_lag_ms > LATE_MS || b.max_ms > LATE_MS ? "bad" : "";
}

function setText(element, text) {
  if (element.textContent !== text) element.textContent = text;
}

function connect() {
  const ws = new WebSocket(`ws://${location.host}/ws`);
  state.ws = ws;
  ws.onopen = () => {
    $("connection").textContent = "live";
    $("connection").className = "good";
    if (state.selected !== null) ws.send(JSON.stringify({ type: "select", slot: state.selected }));
    state.packets = [];
    sendMonitorState();
    sendShownState();
  };
  ws.onclose = () => {
    $("connection").textContent = "disconnected (is the emulator still running?)";
    $("connection").className = "bad";
    setTimeout(connect, 1000);
  };
  ws.onmessage = (m) => {
    const event = JSON.parse(m.data);
    if (event.event === "points") onPoints(event);
    else if (event.event === "telemetry") onTelemetry(event);
    else if (event.event === "packets") addPackets(event.packets);
    else if (event.event === "result") say(event.message, event.ok);
    else if (event.event === "rate") state.rate = event;
  };
}

async function start() {
  state.items = await (await fetch("/api/items")).json();
  const robot = (await (await fetch("/api/robot")).json()).robot;
  if (robot) startRobot(robot);
  buildCharts();
  $("world-load-kind").addEventListener("change", showLoadFields);
  $("world-form").addEventListener("submit", applyWorld);
  $("monitor-pause").addEventListener("change", () => { if (!$("monitor-pause").checked) renderMonitor(); });
  $("monitor-filter").addEventListener("input", renderMonitor);
  $("monitor-export").addEventListener("click", exportCsv);
  $("monitor-clear").addEventListener("click", () => { state.packets = []; renderMonitor(); });
  // Packets come only while the monitor is on screen (the server sends the last seconds when it
  // comes back): a page scrolled to its charts does not parse thousands of packets a second.
  new IntersectionObserver((entries) => {
    const visible = entries.some((e) => e.isIntersecting);
    if (visible === monitorVisible) return;
    monitorVisible = visible;
    if (visible) state.packets = []; // the server sends the kept seconds again
    sendMonitorState();
    if (monitorVisible && !$("monitor-pause").checked) renderMonitor();
  }).observe($("monitor-scroll"));
  const sections = new IntersectionObserver((entries) => {
    for (const e of entries) {
      if (e.target === $("servos")) {
        listVisible = e.isIntersecting;
        if (listVisible) renderServos();
      } else if (e.isIntersecting !== shownVisible) {
        shownVisible = e.isIntersecting;
        sendShownState();
        updateTable(state.table);
      }
    }
  });
  sections.observe($("servos"));
  sections.observe($("selected"));
  connect();
}

start();
