// The Topics page: every topic the robot has (searchable, publishers, a rate on request) and one
// topic live — the message as an expandable JSON tree redrawn at most view_rate_hz (pause
// freezes it), copy, a uPlot of any numeric field clicked in the tree (several on one plot, fed
// by every update the server sends), and recording it (admins; its current policy is shown, and
// one already set is replaced only when the admin says so).
/* global uPlot */
import { attempt, getJSON, notify, request } from "./api.js";
import { readConfig } from "./config.js";
import { live } from "./live.js";
import { fieldsLabel, timeTicks, unitOf } from "./plotaxes.js";
import { formatTime, zone, zoneLabel } from "./time.js";

const config = readConfig("topics-config");
const $ = (id) => document.getElementById(id);
const MAX_POINTS = 1200;
const PLOT_REDRAW_MS = 100;
const NARROW = window.matchMedia("(max-width: 900px)");  // the topic card sits under the list
const COLOURS = ["#1f6feb", "#d1242f", "#1a7f37", "#9a6700", "#8250df", "#0a7ea4", "#bf3989", "#57606a"];

let topics = [];
let current = null; // {name, type, close}
let latest = null; // the newest frame {key, msg, t}
let paused = false;
let renderTimer = null;
let lastRender = 0;
const openPaths = new Set(["[]"]);
let fields = []; // plotted paths (arrays of keys)
let plot = null;
let xs = [];
let ys = [];
let plotTimer = null;

// --- the list -----------------------------------------------------------------------

async function loadTopics() {
  $("topics-count").textContent = "Asking the robot…";
  const answer = await attempt(getJSON(config.urls.topics), { context: "Topics" });
  if (!answer) { $("topics-count").textContent = "The robot's topics are not available."; return; }
  topics = answer.topics;
  renderList();
}

function renderList() {
  const needle = $("topics-search").value.trim().toLowerCase();
  const shown = topics.filter((t) => !needle || t.name.toLowerCase().includes(needle) || t.type.toLowerCase().includes(needle));
  const rows = shown.map((t) => {
    const tr = document.createElement("tr");
    tr.className = "topic-row";
    tr.dataset.topic = t.name;
    tr.setAttribute("aria-selected", String(current?.name === t.name));
    const name = document.createElement("td");
    const open = document.createElement("button");
    open.type = "button";
    open.className = "topic-open";
    open.textContent = t.name;
    const type = document.createElement("div");
    type.className = "topic-type small";
    type.textContent = t.type;
    name.append(open, type);
    const pubs = cell(t.publishers === null ? "?" : t.publishers.join(", ") || "none", "topic-pubs small");
    const rate = document.createElement("td");
    const measure = document.createElement("button");
    measure.type = "button";
    measure.className = "btn rate-btn";
    measure.textContent = "measure";
    measure.title = "Count its messages for 2 s";
    measure.onclick = (e) => { e.stopPropagation(); measureRate(t.name, measure); };
    rate.append(measure);
    tr.append(name, pubs, rate);
    tr.onclick = () => openTopic(t.name, t.type);
    return tr;
  });
  $("topics-rows").replaceChildren(...rows);
  $("topics-count").textContent = `${shown.length} of ${topics.length} topics`;
}

function cell(text, cls) {
  const td = document.createElement("td");
  td.className = cls;
  td.textContent = text;
  return td;
}

async function measureRate(name, button) {
  button.disabled = true;
  button.textContent = "…";
  const url = `${config.urls.rate}?${new URLSearchParams({ topic: name, window_s: "2" })}`;
  const answer = await attempt(getJSON(url), { context: `Rate of ${name}` });
  button.disabled = false;
  button.textContent = answer ? `${answer.hz.toFixed(answer.hz < 10 ? 2 : 1)} Hz` : "measure";
}

// --- one topic ------------------------------------------------------------------------

function openTopic(name, type = "") {
  if (current?.name === name) return;
  current?.close();
  latest = null;
  clearPlot();
  openPaths.clear();
  openPaths.add("[]");
  current = { name, type, close: live.watchTopic(name, onFrame, { onRefused: (error) => onRefused(name, error) }) };
  $("topic-name").textContent = name;
  $("topic-meta").textContent = `${type || "type unknown"} · waiting for a message…`;
  $("topic-meta").classList.remove("topic-refused");
  $("topic-message").replaceChildren();
  for (const id of ["topic-pause", "topic-copy"]) $(id).disabled = false;
  $("topic-record").disabled = $("topic-record").dataset.canRecord !== "1";
  $("topic-policy").textContent = "";
  showPolicy(name);
  for (const tr of document.querySelectorAll(".topic-row")) tr.setAttribute("aria-selected", String(tr.dataset.topic === name));
  history.replaceState(null, "", `?${new URLSearchParams({ topic: name })}`);
  if (NARROW.matches) $("topic-card").scrollIntoView({ block: "start" });
}

function onFrame(frame) {
  latest = frame;
  if (fields.length) addPoint(frame);
  if (!paused) scheduleRender();
}

// Shown in the card for as long as the topic is open (the toast says it too, for a while).
function onRefused(name, error) {
  if (current?.name !== name) return;
  $("topic-meta").textContent = `Cannot watch ${name}: ${error.message}`;
  $("topic-meta").classList.add("topic-refused");
}

function scheduleRender() {
  if (renderTimer) return;
  const wait = Math.max(0, lastRender + 1000 / config.view_rate_hz - performance.now());
  renderTimer = setTimeout(() => { renderTimer = null; lastRender = performance.now(); renderMessage(); }, wait);
}

function renderMessage() {
  if (!latest || !current) return;
  const when = formatTime(latest.t, { label: true });
  $("topic-meta").textContent = `${current.type || "type unknown"} · received ${when}${hasCut(latest.msg) ? " · large arrays and texts summarised" : ""}`;
  const scroll = $("topic-message").scrollTop;
  $("topic-message").replaceChildren(tree(latest.msg, [], "message"));
  $("topic-message").scrollTop = scroll;
}

function hasCut(value) {
  if (value && typeof value === "object") {
    if (value._truncated) return true;
    return Object.values(value).some(hasCut);
  }
  return false;
}

// The JSON tree: objects and arrays as <details> (their open state kept across redraws),
// numbers as buttons that add their field to the plot.
function tree(value, path, label) {
  const id = JSON.stringify(path);
  if (value && typeof value === "object" && value._truncated === "string") {
    return row(label, `"${value.text}…" (${value.length} characters)`, "str");
  }
  if (value && typeof value === "object" && value._truncated === "object") return row(label, "{…}", "cut");
  const isCutArray = value && typeof value === "object" && value._truncated === "array";
  if (Array.isArray(value) || isCutArray || (value && typeof value === "object")) {
    const details = document.createElement("details");
    details.open = openPaths.has(id);
    details.addEventListener("toggle", () => { if (details.open) openPaths.add(id); else openPaths.delete(id); });
    const summary = document.createElement("summary");
    const entries = isCutArray ? value.items.map((v, i) => [i, v]) : Array.isArray(value) ? value.map((v, i) => [i, v]) : Object.entries(value);
    const what = isCutArray ? `[${value.length} items, first ${value.items.length} shown]`
      : Array.isArray(value) ? `[${value.length}]` : `{${entries.length}}`;
    summary.append(keySpan(label), document.createTextNode(` ${what}`));
    details.append(summary);
    if (details.open) for (const [k, v] of entries) details.append(tree(v, [...path, k], k));
    else details.addEventListener("toggle", () => {
      if (details.open && details.children.length === 1) for (const [k, v] of entries) details.append(tree(v, [...path, k], k));
    }, { once: true });
    return details;
  }
  if (typeof value === "number") {
    const div = document.createElement("div");
    div.className = "row";
    const num = document.createElement("button");
    num.type = "button";
    num.className = "num";
    num.dataset.path = id;
    num.textContent = String(value);
    num.title = "Plot this field";
    num.setAttribute("aria-pressed", String(fields.some((f) => JSON.stringify(f) === id)));
    num.onclick = () => togglePlot(path);
    div.append(keySpan(label), document.createTextNode(": "), num);
    return div;
  }
  if (typeof value === "string") return row(label, JSON.stringify(value), "str");
  return row(label, String(value), "lit");
}

function row(label, text, cls) {
  const div = document.createElement("div");
  div.className = "row";
  const span = document.createElement("span");
  span.className = cls;
  span.textContent = text;
  div.append(keySpan(label), document.createTextNode(": "), span);
  return div;
}

function keySpan(label) {
  const span = document.createElement("span");
  span.className = "key";
  span.textContent = String(label);
  return span;
}

// A field's value in a (summarised) message: array summaries are looked through to their items.
function valueAt(msg, path) {
  let cur = msg;
  for (const step of path) {
    if (cur && cur._truncated === "array") cur = cur.items;
    if (cur === null || typeof cur !== "object") return null;
    cur = cur[step];
  }
  return typeof cur === "number" ? cur : null;
}

// --- the plot -------------------------------------------------------------------------

function togglePlot(path) {
  const id = JSON.stringify(path);
  const at = fields.findIndex((f) => JSON.stringify(f) === id);
  if (at >= 0) { fields.splice(at, 1); ys.splice(at, 1); } else { fields.push(path); ys.push(xs.map(() => null)); }
  if (!fields.length) { clearPlot(); renderMessage(); return; }
  if (latest && !xs.length) addPoint(latest);
  buildPlot();
  renderMessage();
}

function addPoint(frame) {
  if (xs.length && frame.t <= xs[xs.length - 1]) return;
  xs.push(frame.t);
  fields.forEach((path, i) => {
    const value = valueAt(frame.msg, path);
    ys[i].push(value == null ? null : value * (fieldUnit(path)?.scale ?? 1)); // battery in %, as labelled
  });
  if (xs.length > MAX_POINTS) { xs.shift(); for (const y of ys) y.shift(); }
  if (!plotTimer) plotTimer = setTimeout(() => { plotTimer = null; plot?.setData([xs, ...ys]); }, PLOT_REDRAW_MS);
}

const fieldUnit = (path) => unitOf(config.units, current?.name, path.join("."));

function buildPlot() {
  plot?.destroy();
  const el = $("topic-plot");
  el.hidden = false;
  $("topic-plot-head").hidden = false;
  $("topic-plot-fields").textContent = fields.map((f) => {
    const unit = fieldUnit(f)?.unit;
    return unit ? `${f.join(".")} (${unit})` : f.join(".");
  }).join(", ");
  plot = new uPlot({
    width: el.clientWidth || 600, height: 220,
    scales: { x: { time: true } },
    tzDate: (ts) => uPlot.tzDate(new Date(ts * 1e3), zone),
    axes: [{ label: `time (${zone}, ${zoneLabel()})`, values: timeTicks, space: 70 },
      { label: fieldsLabel(fields.map((f) => f.join(".")), fields.map(fieldUnit)) }],
    series: [{ value: (u, v) => (v == null ? "—" : formatTime(v, { label: true })) }, ...fields.map((f, i) => ({
      label: f.join("."), stroke: COLOURS[i % COLOURS.length], width: 1.5, spanGaps: true,
      value: (u, v) => (v == null ? "—" : `${+v.toFixed(3)} ${fieldUnit(f)?.unit ?? ""}`.trim()),
    }))],
    legend: { live: true },
  }, [xs, ...ys], el);
}

function clearPlot() {
  plot?.destroy();
  plot = null;
  fields = [];
  xs = [];
  ys = [];
  $("topic-plot").hidden = true;
  $("topic-plot").replaceChildren();
  $("topic-plot-head").hidden = true;
}

// --- actions ----------------------------------------------------------------------------

function togglePause() {
  paused = !paused;
  $("topic-pause").setAttribute("aria-pressed", String(paused));
  $("topic-pause").textContent = paused ? "Resume" : "Pause";
  $("topic-card").classList.toggle("topic-paused", paused);
  if (!paused) scheduleRender();
}

async function copyMessage() {
  if (!latest) { notify("No message to copy yet.", "warn"); return; }
  const text = JSON.stringify(latest.msg, null, 2);
  try {
    await navigator.clipboard.writeText(text);
  } catch {
    const area = document.createElement("textarea");  // plain http: no clipboard API
    area.value = text;
    document.body.append(area);
    area.select();
    document.execCommand("copy");
    area.remove();
  }
  notify(`Copied the message of ${current.name}.`, "ok");
}

// --- recording ---------------------------------------------------------------------------

// A duration as an admin types it in the recording policies ("30 d", "90 min", "1 s").
function duration(s) {
  for (const [unit, size] of [["d", 86400], ["h", 3600], ["min", 60]]) if (s >= size && s % size === 0) return `${s / size} ${unit}`;
  return `${+s.toFixed(3)} s`;
}

function describePolicy(policy) {
  if (!policy || policy.mode === "off") return "Not recorded";
  const how = policy.mode === "every" ? "every message" : `every ${duration(policy.effective_interval_s)}`;
  return `Recorded ${how}, ${policy.retention_s ? `kept ${duration(policy.retention_s)}` : "kept until deleted"}`;
}

// The topic's recording policy as the server has it now (null: none), shown in the card.
async function showPolicy(name) {
  const answer = await attempt(getJSON(config.urls.policies), { context: "Recording policies" });
  if (!answer || current?.name !== name) return undefined;
  const policy = answer.topics.find((p) => p.topic === name) ?? null;
  $("topic-policy").textContent = `${describePolicy(policy)}.`;
  $("topic-policy").dataset.mode = policy?.mode ?? "none";
  return policy;
}

async function record() {
  if (!current) return;
  const name = current.name;
  const policy = await showPolicy(name);
  if (policy === undefined) return;
  if (policy?.mode === config.record_mode) { notify(`${name} is already recorded every message.`, "ok"); return; }
  // Another recording policy is the admin's choice: replaced only when they say so.
  if (policy && policy.mode !== "off"
      && !confirm(`${name}: ${describePolicy(policy).toLowerCase()}. Record every message instead?`)) {
    notify(`${name} kept as it was: ${describePolicy(policy).toLowerCase()}.`, "ok");
    return;
  }
  const body = { topics: [{ topic: name, msg_type: current.type, mode: config.record_mode }] };
  const answer = await attempt(request("PATCH", config.urls.policies, body), { context: `Record ${name}` });
  if (!answer) return;
  await showPolicy(name);
  notify(`${name} is recorded (every message); see History.`, "ok");
}

$("topics-search").addEventListener("input", renderList);
$("topics-refresh").addEventListener("click", loadTopics);
$("topic-pause").addEventListener("click", togglePause);
$("topic-copy").addEventListener("click", copyMessage);
$("topic-record").addEventListener("click", record);
$("topic-plot-clear").addEventListener("click", () => { clearPlot(); renderMessage(); });
window.addEventListener("resize", () => plot?.setSize({ width: $("topic-plot").clientWidth || 600, height: 220 }));

// A topic named in the address opens at once; its type shows when the list arrives.
const asked = new URLSearchParams(location.search).get("topic");
if (asked) openTopic(asked);
loadTopics().then(() => {
  if (current && !current.type) current.type = topics.find((t) => t.name === current.name)?.type ?? "";
});
