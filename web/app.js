// The dashboard: the stream's snapshots drive the map, the charts and the
// vessel table; the operator's edits go through the REST API (api.js), and
// the next snapshot shows their effect. The server marks the page with what
// it is (`<html data-mode="live|replay">`, src/server/web.rs): a replay's
// page offers no editing and shows the replay bar (replay.js).

import { write, read, askToken, token, showError } from "./api.js";
import { MapView, inRegion, ramp } from "./map.js";
import { Series, drawChart } from "./charts.js";
import { GeoOverlay } from "./geo-overlay.js";
import { startReplayBar } from "./replay.js";
import { startLearning } from "./belief.js";

const $ = (id) => document.getElementById(id);
const REPLAY = document.documentElement.dataset.mode === "replay";
const canvas = $("map");
const view = new MapView(canvas);
const geo = new GeoOverlay(canvas, view);
view.onDraw = () => geo.update();
const state = {
  snapshot: null,
  selectedObject: null,
  selectedVessel: null,
  // H(P) from the mission's start: the coordinator's history, then the
  // stream; thinned (every other point) rather than cut when full.
  h: new Series(2000, { thin: true }),
  historyLoads: 0,
  vesselSeries: { u: new Series(), r: new Series(), obs: new Series() },
  tableDrawn: 0,
  snapshots: 0,
};
// For people poking from the console, and for the browser tests.
window.seacover = { view, state, geo, replay: null };
// A learning coordinator's belief, uncertainty and samples (belief.js).
startLearning(view);
// A replay's bar; a seek clears the trails, which would otherwise join the
// old moment to the new one, and starts the H chart again from the
// recording's history up to the new moment.
if (REPLAY) {
  startReplayBar({
    seeking: () => view.trails.clear(),
    sought: () => {
      state.h.clear();
      loadHistory();
    },
  }).then((bar) => {
    window.seacover.replay = bar;
  });
}

// The map's overlays (buttons and north arrow at the top; hint, legend and
// scale bar at the bottom): "fit" keeps the region out from under them.
view.insets = () => {
  const c = canvas.getBoundingClientRect();
  let top = 0;
  let bottom = 0;
  for (const id of ["map-tools", "north-arrow"]) {
    const r = $(id).getBoundingClientRect();
    if (r.width > 0 && r.height > 0) top = Math.max(top, r.bottom - c.top);
  }
  for (const id of ["map-hint", "legend", "scale-bar"]) {
    const r = $(id).getBoundingClientRect();
    if (r.width > 0 && r.height > 0) bottom = Math.max(bottom, c.bottom - r.top);
  }
  return { top: Math.round(top), bottom: Math.round(bottom) };
};

// ---- H(P) history -------------------------------------------------------------

/**
 * Puts the coverage history (GET /api/v1/coverage/history: the mission's,
 * or the recording's up to the replay's time) before what the stream has
 * brought, so that a page opened mid-mission charts H from the start.
 */
async function loadHistory() {
  const load = ++state.historyLoads;
  let history;
  try {
    history = await read("/api/v1/coverage/history");
  } catch (e) {
    console.warn("seacover: no coverage history", e);
    return;
  }
  if (load !== state.historyLoads) return; // a newer load is on its way
  // A tick without a partition (no vessel yet) has H = 0, which is no
  // coverage to chart: it would stretch the axis down to zero.
  state.h.prepend(history.samples.filter((s) => s.H > 0).map((s) => [s.time, s.H]));
  drawCharts();
}

// ---- stream -----------------------------------------------------------------

function setStatus(kind, text) {
  const s = $("status");
  s.dataset.state = kind;
  s.textContent = text;
}

function connect(delay = 500) {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const ws = new WebSocket(`${scheme}://${location.host}/api/v1/stream`);
  let opened = false;
  ws.onopen = () => {
    opened = true;
    if (REPLAY) setStatus("replay", "replay");
    else setStatus("live", "live");
  };
  ws.onmessage = (event) => {
    try {
      const started = performance.now();
      onSnapshot(JSON.parse(event.data));
      // Cost of taking in one snapshot (ms, moving average).
      const ms = performance.now() - started;
      state.snapshotMs = state.snapshotMs === undefined ? ms : 0.9 * state.snapshotMs + 0.1 * ms;
    } catch (e) {
      console.warn("seacover: a snapshot could not be shown", e);
    }
  };
  ws.onclose = () => {
    // Reconnect with backoff: 0.5 s doubling to 5 s, reset once connected.
    const next = opened ? 500 : Math.min(delay * 2, 5000);
    setStatus("lost", `reconnecting in ${(next / 1000).toFixed(1)} s`);
    setTimeout(() => {
      setStatus("connecting", "connecting…");
      connect(next);
    }, next);
  };
  ws.onerror = () => ws.close();
}

function onSnapshot(snap) {
  state.snapshot = snap;
  state.snapshots += 1;
  document.body.dataset.tick = String(snap.tick);
  view.setSnapshot(snap);
  if (state.streamed !== undefined && snap.time < state.streamed) {
    // Back in time (a replay sought backwards, a coordinator restarted):
    // the history up to the new moment.
    state.h.clear();
    loadHistory();
  }
  state.streamed = snap.time;
  // A snapshot the history already holds (sent before it was read) is not
  // charted twice.
  const last = state.h.last();
  if ((!last || snap.time > last[0]) && snap.H > 0) state.h.push(snap.time, snap.H);
  if (window.seacover.replay) window.seacover.replay.shown(snap.time);
  const live = snap.vessels.filter((v) => v.live).length;
  $("summary").textContent =
    `t = ${snap.time.toFixed(1)} s · H = ${snap.H.toFixed(1)} · ${live}/${snap.vessels.length} vessels live`;
  if (document.activeElement !== $("base-input")) $("base-input").value = snap.mission.risk.base;
  const n = snap.mission.risk.objects.length;
  $("risk-readout").textContent = `base φ₀ = ${snap.mission.risk.base} · ${n} object${n === 1 ? "" : "s"}`;
  syncObjectForm();
  const v = snap.vessels.find((v) => v.id === state.selectedVessel);
  if (v && v.pose) {
    const cmd = v.last_command;
    state.vesselSeries.u.push(snap.time, v.pose.u, cmd ? cmd.u_d : NaN);
    state.vesselSeries.r.push(snap.time, v.pose.r, cmd ? cmd.r_d : NaN);
    const tel = v.pose.telemetry;
    if (tel && tel.tau_d && tel.tau_d_hat) {
      const e = Math.hypot(...tel.tau_d.map((d, k) => d - tel.tau_d_hat[k]));
      state.vesselSeries.obs.push(snap.time, e);
    }
  }
  // The table is DOM: redraw it at most 4 times a second.
  const now = performance.now();
  if (now - state.tableDrawn > 250) {
    state.tableDrawn = now;
    drawTable(snap);
  }
  drawCharts();
}

// ---- vessel table -------------------------------------------------------------

/**
 * How long a vessel whose link closed stays in the table [mission s]: the
 * coordinator keeps its entry (GET /api/v1/vessels lists it, DELETE forgets
 * it), but a table of every boat that ever connected helps nobody.
 */
const GONE_AFTER = 60;

function drawTable(snap) {
  const body = $("vessels").tBodies[0];
  const vessels = snap.vessels.filter(
    (v) => v.connected || (v.last_seen != null && snap.time - v.last_seen <= GONE_AFTER),
  );
  // A peer fleet (serve --peer) has one more column: each vessel's own
  // neighbour count, as it reports it.
  const peer = vessels.some((v) => v.neighbours != null);
  const head = $("vessels").tHead.rows[0];
  if ((head.cells.length > 5) !== peer) {
    if (peer) {
      const th = document.createElement("th");
      th.className = "num";
      th.title = "the neighbours in the vessel's own partition, as it reports them (peer fleet)";
      th.textContent = "nbrs";
      head.appendChild(th);
    } else {
      head.deleteCell(5);
    }
  }
  const ids = vessels.map((v) => v.id).join("\n") + (peer ? "\npeer" : "");
  // Rows are rebuilt only when the fleet changes; otherwise their cells are
  // updated in place, so a row under the pointer stays the same element.
  if (body.dataset.ids !== ids) {
    body.dataset.ids = ids;
    body.innerHTML = vessels
      .map((v) => `<tr data-vessel-id="${escape(v.id)}"><td>${escape(v.id)}</td><td></td>`
        + '<td class="num"></td><td class="num"></td><td class="num"></td>'
        + (peer ? '<td class="num"></td>' : "") + "</tr>")
      .join("");
  }
  vessels.forEach((v, i) => {
    const row = body.rows[i];
    const cells = row.cells;
    // A quarantined vessel (its poses refused) is out of the partition and
    // held: "held", the reason on hover and for screen readers.
    const held = v.quarantine || null;
    const link = v.connected ? (held ? "held" : v.live ? "live" : "silent") : "off";
    // A vessel an operator has taken over (an autopilot out of GUIDED)
    // keeps its cell but follows no command: a compact badge, the detail
    // on hover (and in text for screen readers), so the table stays narrow.
    const mode = v.pose && v.pose.telemetry && v.pose.telemetry.mode;
    const operator = v.controlled === false;
    drawLink(cells[1], link, operator, mode, held);
    cells[1].className = !v.connected ? "off" : held ? "held" : operator ? "operator" : "";
    cells[2].textContent = v.last_command ? v.last_command.E.toFixed(2) : "–";
    cells[3].textContent = v.pose ? Math.hypot(v.pose.u, v.pose.v).toFixed(2) : "–";
    cells[4].textContent = v.last_seen == null ? "never" : Math.max(0, snap.time - v.last_seen).toFixed(1);
    if (peer) cells[5].textContent = v.neighbours == null ? "–" : String(v.neighbours);
    row.classList.toggle("selected", v.id === state.selectedVessel);
  });
  const gone = snap.vessels.length - vessels.length;
  $("vessel-count").textContent = `(${vessels.length}${gone ? ` · ${gone} gone` : ""})`;
}

/** The link cell: its state, and an operator's badge; rebuilt on change only. */
function drawLink(cell, link, operator, mode, held) {
  const key = `${link}|${operator}|${mode || ""}|${held ? held.reason : ""}`;
  if (cell.dataset.key === key) return;
  cell.dataset.key = key;
  cell.textContent = link;
  cell.title = "";
  if (held) {
    const spoken = document.createElement("span");
    spoken.className = "sr-only";
    spoken.textContent = ` · quarantined: ${held.reason}`;
    cell.append(spoken);
    cell.title = `quarantined since ${held.since.toFixed(1)} s (${held.refused} poses refused): `
      + `${held.reason}; out of the partition and told to hold`;
    return;
  }
  if (!operator) return;
  const detail = `operator${mode ? ` (${mode})` : ""}`;
  const badge = document.createElement("span");
  badge.className = "badge";
  badge.textContent = "op";
  badge.setAttribute("aria-hidden", "true");
  const spoken = document.createElement("span");
  spoken.className = "sr-only";
  spoken.textContent = ` · ${detail}`;
  cell.append(badge, spoken);
  cell.title = `${link} · ${detail}: not under control, the coordinator's commands are not followed`;
}

function escape(s) {
  return String(s).replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`);
}

$("vessels").tBodies[0].addEventListener("click", (event) => {
  const row = event.target.closest("tr[data-vessel-id]");
  if (!row) return;
  selectVessel(row.dataset.vesselId === state.selectedVessel ? null : row.dataset.vesselId);
});

function selectVessel(id) {
  state.selectedVessel = id;
  view.selectedVessel = id;
  view.follow = id !== null;
  for (const s of Object.values(state.vesselSeries)) s.clear();
  $("vessel-charts").hidden = id === null;
  $("chart-vessel").textContent = id ?? "";
  view.dirty = true;
  if (state.snapshot) drawTable(state.snapshot);
}

// ---- charts ---------------------------------------------------------------------

function drawCharts() {
  drawChart($("chart-h"), state.h, ["H(P)"], ["#4fb3ff"]);
  if (state.selectedVessel) {
    // The command dashed and under what the hull did, which stays in view
    // where it follows the command exactly.
    const commanded = [[], [5, 4]];
    drawChart($("chart-u"), state.vesselSeries.u, ["u", "u_d"], ["#7be07b", "#ffb84f"], commanded);
    drawChart($("chart-r"), state.vesselSeries.r, ["r", "r_d"], ["#7be07b", "#ffb84f"], commanded);
    drawChart($("chart-obs"), state.vesselSeries.obs, ["‖τ_d − τ̂_d‖"], ["#ff7bd5"]);
  }
}

// ---- legend ---------------------------------------------------------------------

const LEGEND = { mission: "Φ", belief: "Φ learned", uncertainty: "σ of Φ" };

view.onLegend = (min, max, layer) => {
  $("legend-label").textContent = LEGEND[layer] || "Φ";
  const bar = $("legend-bar");
  const ctx = bar.getContext("2d");
  for (let i = 0; i < bar.width; i++) {
    const [r, g, b] = ramp(i / (bar.width - 1));
    ctx.fillStyle = `rgb(${r},${g},${b})`;
    ctx.fillRect(i, 0, 1, bar.height);
  }
  $("legend-min").textContent = min.toPrecision(3);
  $("legend-max").textContent = max.toPrecision(3);
};

// ---- risk objects ---------------------------------------------------------------

function objects() {
  return state.snapshot ? state.snapshot.mission.risk.objects : [];
}

function selectObject(id) {
  state.selectedObject = id;
  view.selectedObject = id;
  view.dirty = true;
  const form = $("object-form");
  form.hidden = id === null;
  if (id !== null) {
    const o = objects().find((o) => o.id === id);
    if (o) {
      $("object-id").textContent = id;
      $("alpha-input").value = o.alpha;
      $("sigma-input").value = o.sigma;
    }
  }
}

function syncObjectForm() {
  if (state.selectedObject && !objects().some((o) => o.id === state.selectedObject)) selectObject(null);
}

function regionSize() {
  const p = state.snapshot.mission.region.polygon;
  const xs = p.map((q) => q[0]);
  const ys = p.map((q) => q[1]);
  return Math.max(Math.max(...xs) - Math.min(...xs), Math.max(...ys) - Math.min(...ys));
}

async function addObject(x, y) {
  const sigma = +(regionSize() * 0.08).toPrecision(3);
  try {
    const created = await write("POST", "/api/v1/risk-objects", { x, y, alpha: 10, sigma });
    // Show it at once; the stream confirms it within a tick.
    state.snapshot.mission.risk.objects.push(created);
    selectObject(created.id);
  } catch {
    // write() has shown the error.
  }
}

async function moveObject(id, x, y) {
  const o = objects().find((o) => o.id === id);
  if (!o) return;
  try {
    const saved = await write("PUT", `/api/v1/risk-objects/${encodeURIComponent(id)}`, {
      x, y, alpha: o.alpha, sigma: o.sigma,
    });
    Object.assign(o, saved);
  } catch {
    // Shown; the next snapshot puts it back where the server has it.
  }
  view.dragObject = null;
  view.dirty = true;
}

$("object-form").addEventListener("submit", async (event) => {
  event.preventDefault();
  const id = state.selectedObject;
  const o = objects().find((o) => o.id === id);
  if (!o) return;
  try {
    const saved = await write("PUT", `/api/v1/risk-objects/${encodeURIComponent(id)}`, {
      x: o.x, y: o.y, alpha: Number($("alpha-input").value), sigma: Number($("sigma-input").value),
    });
    Object.assign(o, saved);
    view.dirty = true;
  } catch {
    // Shown.
  }
});

$("object-delete").addEventListener("click", async () => {
  const id = state.selectedObject;
  if (!id) return;
  try {
    await write("DELETE", `/api/v1/risk-objects/${encodeURIComponent(id)}`);
    const list = objects();
    const i = list.findIndex((o) => o.id === id);
    if (i >= 0) list.splice(i, 1);
    selectObject(null);
  } catch {
    // Shown.
  }
});

$("object-close").addEventListener("click", () => selectObject(null));

$("base-form").addEventListener("submit", async (event) => {
  event.preventDefault();
  try {
    await write("PUT", "/api/v1/mission/risk/base", { value: Number($("base-input").value) });
  } catch {
    // Shown.
  }
  $("base-input").blur();
});

// A GeoTIFF replaces the mission's risk by its fit (docs/rasters.md); the
// readout says how well the fit matches the raster.
$("raster-input").addEventListener("change", async () => {
  const input = $("raster-input");
  const file = input.files[0];
  if (!file) return;
  const readout = $("raster-readout");
  readout.textContent = `fitting ${file.name}…`;
  try {
    const answer = await write("PUT", "/api/v1/mission/risk/raster", file, "image/tiff");
    const f = answer.fit;
    const pct = (x) => (100 * x).toFixed(2);
    readout.textContent =
      `${file.name} (${f.crs}, ${f.width} × ${f.height}): ` +
      `${answer.mission.risk.objects.length} Gaussians of σ ${f.spacing.toPrecision(3)} m; ` +
      `error RMS ${pct(f.rms)} %, max ${pct(f.worst)} % of the raster's range`;
    state.snapshot.mission = answer.mission;
    view.dirty = true;
  } catch (e) {
    readout.textContent = `${file.name} not loaded: ${e.message}`;
  }
  input.value = "";
});

$("token-button").addEventListener("click", async () => {
  await askToken(token() ? "Replace the stored token:" : "Token for changes:");
});

// ---- pointer: click adds, drag moves an object or pans, wheel zooms ----------

let press = null; // { id, x, y, object, moved }
const pointers = new Map();

function local(event) {
  const r = canvas.getBoundingClientRect();
  return [event.clientX - r.left, event.clientY - r.top];
}

canvas.addEventListener("pointerdown", (event) => {
  canvas.setPointerCapture(event.pointerId);
  const [sx, sy] = local(event);
  pointers.set(event.pointerId, [sx, sy]);
  if (pointers.size > 1) {
    press = null; // a pinch, not a click
    return;
  }
  // A replay's objects are not edited: a press only pans.
  const object = REPLAY ? null : view.objectAt(sx, sy);
  press = { x: sx, y: sy, lastX: sx, lastY: sy, object: object ? object.id : null, moved: false };
});

canvas.addEventListener("pointermove", (event) => {
  const [sx, sy] = local(event);
  if (pointers.size === 2 && pointers.has(event.pointerId)) {
    const [a, b] = [...pointers.values()];
    const before = Math.hypot(a[0] - b[0], a[1] - b[1]);
    pointers.set(event.pointerId, [sx, sy]);
    const [c, d] = [...pointers.values()];
    const after = Math.hypot(c[0] - d[0], c[1] - d[1]);
    if (before > 0) view.zoom(after / before, (c[0] + d[0]) / 2, (c[1] + d[1]) / 2);
    return;
  }
  if (pointers.has(event.pointerId)) pointers.set(event.pointerId, [sx, sy]);
  if (!press) return;
  if (!press.moved && Math.hypot(sx - press.x, sy - press.y) < 4) return;
  press.moved = true;
  canvas.classList.add("dragging");
  if (press.object) {
    const [wx, wy] = view.toWorld(sx, sy);
    view.dragObject = { id: press.object, x: wx, y: wy };
    view.dirty = true;
  } else {
    view.follow = false;
    view.pan(sx - press.lastX, sy - press.lastY);
  }
  press.lastX = sx;
  press.lastY = sy;
});

function release(event) {
  pointers.delete(event.pointerId);
  canvas.classList.remove("dragging");
  const p = press;
  press = null;
  if (!p || event.type === "pointercancel" || !state.snapshot) return;
  const [sx, sy] = local(event);
  const [wx, wy] = view.toWorld(sx, sy);
  if (p.object && p.moved) {
    moveObject(p.object, wx, wy);
  } else if (p.object) {
    selectObject(p.object);
  } else if (!p.moved && !REPLAY && inRegion(state.snapshot.mission.region, wx, wy)) {
    // Risk lies on the water of Q: a click on land or outside adds nothing.
    addObject(wx, wy);
  }
}
canvas.addEventListener("pointerup", release);
canvas.addEventListener("pointercancel", release);

canvas.addEventListener("wheel", (event) => {
  event.preventDefault();
  const [sx, sy] = local(event);
  view.zoom(Math.exp(-event.deltaY * 0.0015), sx, sy);
}, { passive: false });

$("zoom-in").addEventListener("click", () => view.zoom(1.25));
$("zoom-out").addEventListener("click", () => view.zoom(0.8));
$("zoom-fit").addEventListener("click", () => {
  view.follow = false;
  view.fit();
});

window.addEventListener("unhandledrejection", (event) => {
  showError(`unexpected: ${event.reason}`);
});

// `?vessel=ID` opens the page following that vessel (links can be shared).
const wanted = new URLSearchParams(location.search).get("vessel");
if (wanted) selectVessel(wanted);

connect();
loadHistory();
