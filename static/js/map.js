// The map page: the server-rendered map image with a live overlay (robot, path, goal,
// named locations), zoom/pan/pinch, press-drag-release goals and initial poses.
import { deleteJSON, getJSON, notify, postJSON, request } from "./api.js";
import { sendCommand } from "./commands.js";
import { readConfig } from "./config.js";
import { live } from "./live.js";
import { drawOverlay } from "./map/draw.js";
import { attachGestures } from "./map/gestures.js";
import { OVERLAYS, Overlays, swatchFill } from "./map/overlays.js";
import { distanceLeft, formatLeft, Progress } from "./map/progress.js";
import { formatMetres, quaternionToYaw, scaleBar, View } from "./map/view.js";

const config = readConfig("map-config");
const locationURL = (template, name) => template.replace("{name}", encodeURIComponent(name));
const root = document.getElementById("map-view");
const img = document.getElementById("map-image");
const canvas = document.getElementById("map-overlay");
const ctx = canvas.getContext("2d");
const canCommand = root.dataset.canCommand === "1";
const $ = (id) => document.getElementById(id);
const TERMINAL = new Set(["succeeded", "aborted", "cancelled", "rejected", "lost"]);

const view = new View();
const state = {
  robot: null, plan: [], goal: null, statuses: { goals: {} }, currentLocation: "",
  locations: config.locations, drag: null, mode: "pan",
};
let viewFitted = false;
let drawQueued = false;

// --- drawing ---------------------------------------------------------------------------

// As the server's goal_view: the latest goal wins, ours or one another tool sent (an id not ours).
function newestForeignGoal() {
  let newest = null;
  for (const [id, s] of Object.entries(state.statuses.goals || {})) {
    if (id.startsWith(config.goal_id_prefix)) continue;
    const since = s.since ?? s.t;
    if (!newest || since > newest.since) newest = { id, since, s };
  }
  return newest;
}

function currentGoal() {
  const goal = state.goal;
  const foreign = newestForeignGoal();
  if (foreign && (!goal || foreign.since > goal.sent)) {
    const s = foreign.s;
    return { id: foreign.id, action: s.action || "move_base", x: null, y: null, yaw: null, location: null,
      by: config.foreign_goal_by, sent: foreign.since, foreign: true, status: s.state, status_text: s.text || "",
      finished: TERMINAL.has(s.state) };
  }
  if (!goal) return null;
  const reported = state.statuses.goals?.[goal.id];
  let status = reported ? reported.state : "pending";
  if (goal.cancel_requested && (status === "pending" || status === "active")) status = "cancelling";
  return { ...goal, foreign: false, status, status_text: reported?.text || "", finished: TERMINAL.has(status) };
}

function scheduleDraw() {
  if (drawQueued) return;
  drawQueued = true;
  requestAnimationFrame(() => {
    drawQueued = false;
    const dpr = window.devicePixelRatio || 1;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    drawOverlay(ctx, view, { ...state, goal: currentGoal(), overlays }, dpr);
    renderOverlayNotes();
    if (view.meta && img.complete && img.naturalWidth) root.dataset.ready = "1";
  });
}

function renderScale() {
  const bar = scaleBar(view);
  const el = $("map-scale");
  el.hidden = false;
  el.dataset.metres = String(bar.metres);
  el.querySelector(".map-scale-bar").style.width = `${bar.px}px`;
  el.querySelector(".map-scale-label").textContent = formatMetres(bar.metres);
}

function applyView() {
  if (!view.meta) return;
  img.style.transform = `translate(${view.tx}px, ${view.ty}px) scale(${view.scale})`;
  img.classList.toggle("pixelated", view.scale >= 2);
  renderScale();
  scheduleDraw();
}

function resize() {
  const { width, height } = root.getBoundingClientRect();
  const dpr = window.devicePixelRatio || 1;
  canvas.width = Math.round(width * dpr);
  canvas.height = Math.round(height * dpr);
  canvas.style.width = `${width}px`;
  canvas.style.height = `${height}px`;
  if (view.meta && !viewFitted && img.naturalWidth) { view.fit(width, height); viewFitted = true; }
  applyView();
  scheduleDraw();
}

function fit() {
  const { width, height } = root.getBoundingClientRect();
  view.fit(width, height);
  applyView();
}

function showMap(meta) {
  if (!meta || meta.version === root.dataset.mapVersion) return;
  const sameSize = view.meta && view.meta.width === meta.width && view.meta.height === meta.height;
  root.dataset.mapVersion = meta.version;
  $("map-empty").hidden = true;
  $("map-info").textContent = `${meta.width} × ${meta.height} cells · ${meta.resolution} m/cell`;
  img.onload = () => {
    view.meta = meta;
    if (!sameSize || !viewFitted) { fit(); viewFitted = true; }
    applyView();
  };
  img.src = meta.image_url;
}

// --- overlays (laser, costmaps, particles, footprint, local plan) ------------------------

const overlays = new Overlays({
  enabled: config.overlays,
  redraw: scheduleDraw,
  async save(name, on) {
    try { await request("PATCH", config.urls.overlays, { [name]: on }); } catch (err) { notify(`Overlay not saved: ${err.message}`, "error"); }
  },
});

function renderOverlayToggles() {
  const list = $("overlay-list");
  for (const o of OVERLAYS) {
    const li = document.createElement("li");
    const label = document.createElement("label");
    const box = document.createElement("input");
    box.type = "checkbox";
    box.dataset.overlay = o.name;
    box.checked = Boolean(overlays.enabled[o.name]);
    box.onchange = () => overlays.toggle(o.name, box.checked);
    const swatch = document.createElement("span");
    swatch.className = `swatch ov-${o.name}`;
    swatch.style.background = swatchFill(o.name);
    label.append(box, swatch, ` ${o.label}`);
    const note = document.createElement("span");
    note.className = "muted small overlay-note";
    note.dataset.note = o.name;
    li.append(label, note);
    list.append(li);
  }
}

function renderOverlayNotes() {
  for (const o of OVERLAYS) {
    const el = document.querySelector(`[data-note="${o.name}"]`);
    const text = overlays.describe(o.name);
    if (el && el.textContent !== text) el.textContent = text;
  }
  const scan = overlays.enabled.scan && overlays.data.scan;
  root.dataset.scanPoints = scan?.points ? String(scan.points.length / 2) : "";
}

// --- live updates ----------------------------------------------------------------------

const onUpdate = {
  robot_pose(m) {
    state.robot = { x: m.position.x, y: m.position.y, yaw: quaternionToYaw(m.orientation) };
    root.dataset.robotX = state.robot.x.toFixed(3);
    root.dataset.robotY = state.robot.y.toFixed(3);
    $("robot-pose").textContent =
      `x ${state.robot.x.toFixed(2)} m · y ${state.robot.y.toFixed(2)} m · ${(state.robot.yaw * 180 / Math.PI).toFixed(0)}°`;
    renderProgress();
  },
  plan(m) { state.plan = (m.poses || []).map((p) => [p.pose.position.x, p.pose.position.y]); },
  bumper_state(m) {
    state.bumpers = m;
    const pressed = [...(m.front_bumpers || []), ...(m.rear_bumpers || [])].some(Boolean);
    root.dataset.bumped = pressed ? "1" : "";
  },
  at_location(m) {
    state.currentLocation = m.name;
    $("current-location").textContent = m.name || "(none)";
  },
  map_meta(m) { showMap(m); },
  nav_goal(m) { state.goal = m; renderGoal(); },
  nav_goal_status(m) { state.statuses = m; renderGoal(); },
  nav_locations(m) { state.locations = m.locations; renderLocations(); },
  motors_state(m) { $("goal-motors-off").hidden = m.data !== false; },
};

function renderGoal() {
  const goal = currentGoal();
  const pill = $("goal-status");
  pill.textContent = goal ? goal.status : "no goal";
  pill.className = `pill goal-${goal ? goal.status : "none"}`;
  root.dataset.goalStatus = goal ? goal.status : "";
  root.dataset.goalId = goal ? goal.id : "";
  root.dataset.goalForeign = goal?.foreign ? "1" : "";
  $("goal-target").textContent = !goal ? "—"
    : goal.foreign ? `sent by ${goal.by}`
    : `${goal.location ? goal.location + " · " : ""}x ${goal.x.toFixed(2)} · y ${goal.y.toFixed(2)} · ${(goal.yaw * 180 / Math.PI).toFixed(0)}° (by ${goal.by || "?"})`;
  $("goal-text").textContent = goal?.status_text || "";
  renderProgress(goal);
  scheduleDraw();
}

const progress = new Progress();
function renderProgress(goal = currentGoal()) {
  const underWay = goal && !goal.finished;
  const left = progress.update(underWay ? goal.id : null,
    underWay ? distanceLeft(state.robot, goal, state.plan) : null, Date.now() / 1000);
  $("goal-left").textContent = formatLeft(left);
  root.dataset.goalMetres = left.metres == null ? "" : left.metres.toFixed(2);
}

// What the cancel did, in the operator's words (the audit keeps the goal's id).
function cancelText(result) {
  const goal = result.goal;
  if (!goal) return "Navigation stopped: no goal of ours was under way.";
  const which = goal.foreign ? `The goal ${goal.by} sent`
    : `The goal to ${goal.location || `(${goal.x.toFixed(2)}, ${goal.y.toFixed(2)})`}`;
  return goal.finished && !result.cancel_sent ? `${which} had already ended (${goal.status}).`
    : `Cancelling ${which.charAt(0).toLowerCase()}${which.slice(1)}.`;
}

// --- commands --------------------------------------------------------------------------

function setMode(mode) {
  state.mode = mode;
  root.dataset.mode = mode;
  document.querySelectorAll("[data-mode]").forEach((b) => b.setAttribute("aria-pressed", String(b.dataset.mode === mode)));
}

// Why the last press sent nothing (off the map, motors off…), on the map where the press was.
let messageTimer = null;
function showMapMessage(text) {
  const el = $("map-message");
  el.textContent = text;
  el.hidden = !text;
  clearTimeout(messageTimer);
  if (text) messageTimer = setTimeout(() => { el.hidden = true; }, 10000);
}

// A refused press keeps its tool, so the next press aims again instead of panning.
async function sendAim(mode, x, y, yaw) {
  const url = mode === "pose" ? config.urls.initial_pose : config.urls.goal;
  let sent = false;
  try {
    const res = await postJSON(url, { x, y, yaw });
    sent = true;
    showMapMessage("");
    notify(mode === "pose" ? res.detail : `Goal sent to (${x.toFixed(2)}, ${y.toFixed(2)})`, "ok", { timeout: 3000 });
  } catch (err) {
    showMapMessage(`${mode === "pose" ? "Pose" : "Goal"} not sent: ${err.message}`);
    notify(err.message, "error");
  } finally {
    state.drag = null;
    if (sent) setMode("pan");
    scheduleDraw();
  }
}

function aimAt(start, end) {
  const [x, y] = view.toMap(start.x, start.y);
  let yaw;
  if (end && Math.hypot(end.x - start.x, end.y - start.y) > 6) yaw = view.headingOf(start.x, start.y, end.x, end.y);
  else yaw = state.robot ? Math.atan2(y - state.robot.y, x - state.robot.x) : 0; // face the way there
  return { x, y, yaw };
}

attachGestures(canvas, view, {
  getMode: () => (view.meta && canCommand ? state.mode : "pan"),
  onView: applyView,
  onHover(sx, sy) {
    if (!view.meta) return;
    const [x, y] = view.toMap(sx, sy);
    $("map-cursor").textContent = `x ${x.toFixed(2)} m · y ${y.toFixed(2)} m`;
  },
  onLeave() { $("map-cursor").textContent = "—"; },
  onAim(start, end) {
    state.drag = start ? { ...aimAt(start, end), mode: state.mode } : null;
    scheduleDraw();
  },
  onRelease(start, end) {
    const aim = aimAt(start, end);
    state.drag = { ...aim, mode: state.mode };
    scheduleDraw();
    sendAim(state.mode, aim.x, aim.y, aim.yaw);
  },
});

document.querySelectorAll("[data-mode]").forEach((b) => b.addEventListener("click", () => setMode(b.dataset.mode)));
$("zoom-in").onclick = () => { const r = root.getBoundingClientRect(); view.zoomAt(r.width / 2, r.height / 2, 1.4); applyView(); };
$("zoom-out").onclick = () => { const r = root.getBoundingClientRect(); view.zoomAt(r.width / 2, r.height / 2, 1 / 1.4); applyView(); };
$("zoom-fit").onclick = () => view.meta && fit();
$("goal-motors-enable")?.addEventListener("click", (ev) => sendCommand("motors", { enabled: true }, { control: ev.currentTarget }));
$("goal-cancel").onclick = async () => {
  try { notify(cancelText(await postJSON(config.urls.cancel)), "info", { timeout: 3000 }); } catch (err) { notify(err.message, "error"); }
};

// --- named locations -------------------------------------------------------------------

async function reloadLocations() {
  state.locations = await getJSON(config.urls.locations);
  renderLocations();
}

function renderLocations() {
  const list = $("location-list");
  const select = $("send-to");
  list.replaceChildren();
  select.replaceChildren(new Option("Send to…", ""));
  for (const loc of state.locations) {
    select.append(new Option(loc.name, loc.name));
    const li = document.createElement("li");
    li.dataset.location = loc.name;
    const name = document.createElement("span");
    name.className = "loc-name";
    name.textContent = loc.name;
    name.title = loc.description || "";
    const where = document.createElement("span");
    where.className = "muted small";
    where.textContent = `${loc.x.toFixed(2)}, ${loc.y.toFixed(2)} m · ${(loc.yaw * 180 / Math.PI).toFixed(0)}°`;
    const go = button("Go", () => goTo(loc.name), "btn btn-small");
    const del = button("×", () => removeLocation(loc.name), "btn btn-small");
    del.setAttribute("aria-label", `Delete ${loc.name}`);
    li.append(name, where, go, del);
    list.append(li);
  }
  $("locations-empty").hidden = state.locations.length > 0;
  scheduleDraw();
}

function button(text, onclick, className) {
  const b = document.createElement("button");
  b.type = "button"; b.className = className; b.textContent = text; b.onclick = onclick; b.disabled = !canCommand;
  return b;
}

async function goTo(name) {
  try {
    await postJSON(locationURL(config.urls.location_go, name));
    notify(`Sending the robot to ${name}`, "ok", { timeout: 3000 });
  } catch (err) { showMapMessage(`Goal not sent: ${err.message}`); notify(err.message, "error"); }
}

async function removeLocation(name) {
  if (!confirm(`Delete the location “${name}”?`)) return;
  try { await deleteJSON(locationURL(config.urls.location, name)); await reloadLocations(); } catch (err) { notify(err.message, "error"); }
}

$("send-to-btn").onclick = () => $("send-to").value && goTo($("send-to").value);
$("save-pose-form").onsubmit = async (ev) => {
  ev.preventDefault();
  const name = $("save-pose-name").value.trim();
  try {
    await postJSON(config.urls.locations, { name, use_current_pose: true });
    $("save-pose-name").value = "";
    notify(`Saved the robot's pose as ${name}`, "ok", { timeout: 3000 });
    await reloadLocations();
  } catch (err) { notify(err.message, "error"); }
};

// --- start -----------------------------------------------------------------------------

window.cyborgMap = {
  view, state, overlays,
  // Page coordinates of a map point (tests aim the mouse with this).
  toClient(x, y) {
    const r = root.getBoundingClientRect();
    const [sx, sy] = view.toScreen(x, y);
    return [r.left + sx, r.top + sy];
  },
};

setMode("pan");
renderOverlayToggles();
renderLocations();
renderGoal();
new ResizeObserver(resize).observe(root);
showMap(config.map);
let opened = false;
live.watch(config.keys, (f) => { onUpdate[f.key]?.(f.msg); scheduleDraw(); });
// Changes are only sent while connected: after a reconnect, fetch what may have been missed.
live.onOpen(() => { if (opened) reloadLocations().catch(() => {}); opened = true; });
