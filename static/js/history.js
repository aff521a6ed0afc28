// The plots page: downsampled series from the history API drawn with uPlot
// (mean line, min/max band so spikes stay visible; zooming fetches finer buckets),
// text topics as a table of messages, presets, state timeline (zoomed the same way), exports.
import { getJSON, notify } from "./api.js";
import { readConfig } from "./config.js";
import { formatDuration, formatTime, parseSiteTime, toSiteInput, zone, zoneLabel } from "./time.js";
import { timeTicks, valueLabel } from "./plotaxes.js";
import { dragToZoom, renderTimeline } from "./timeline.js";

const config = readConfig("history-config");
const $ = (id) => document.getElementById(id);
const RANGES = { hour: 3600, day: 86400, week: 7 * 86400 };
const COLORS = ["#2563eb", "#dc2626", "#059669", "#d97706", "#7c3aed"];
const TABLE = "@messages"; // the Field choice that shows a topic's messages as a table
const TIMELINE = "@timeline"; // the state topic's Field choice that shows the state timeline
const MESSAGES_LIMIT = 500;
let chart = null;
let shown = null; // what the chart shows: {topic, fields, opts}, or the timeline: {timeline: true}

function fillTopics(selected) {
  const topics = $("topic");
  topics.replaceChildren(...config.topics.map((t) => new Option(`${t.topic} (${t.msg_type})`, t.topic)));
  if (selected) topics.value = selected;
  fillFields();
}

function fillFields(selected) {
  const topic = config.topics.find((t) => t.topic === $("topic").value);
  const fields = topic ? topic.fields : [];
  const options = fields.map((f) => new Option(f, f));
  const text = topic && (topic.text || !fields.length);
  if (text) options.unshift(new Option("messages (table)", TABLE));
  const states = topic?.topic === config.state_topic;
  if (states) options.unshift(new Option("state timeline", TIMELINE));
  $("field").replaceChildren(...options);
  if (selected && (fields.includes(selected) || selected === TABLE || selected === TIMELINE)) $("field").value = selected;
  else if (states) $("field").value = TIMELINE;
  else if (text) $("field").value = TABLE;
}

// Show one of the three views (chart, timeline, messages); the others go away.
function showView(name) {
  for (const view of ["chart", "timeline", "messages"]) $(view).hidden = view !== name;
  if (name !== "chart") {
    if (chart) { chart.destroy(); chart = null; }
    shown = name === "timeline" ? { timeline: true } : null;
  }
  $("zoom-out").hidden = true;
  $("zoom-hint").hidden = name === "messages";
}

function range() {
  const choice = $("range").value;
  if (choice === "custom") {
    const start = parseSiteTime($("start").value);
    const end = parseSiteTime($("end").value);
    if (!isFinite(start) || !isFinite(end)) throw new Error(`Write From and To as YYYY-MM-DD HH:MM (${zone} time).`);
    if (start >= end) throw new Error("Pick a start before the end.");
    return { start, end };
  }
  const end = Date.now() / 1000;
  return { start: end - RANGES[choice], end };
}

function seriesURL(topic, field, { start, end }) {
  const q = new URLSearchParams({ topic, field, start, end, max_points: 2000 });
  return `${config.urls.samples}?${q}`;
}

// Join several series on their bucket times (same topic and range → same grid).
function align(results, scale) {
  const times = [...new Set(results.flatMap((r) => r.t))].sort((a, b) => a - b);
  const index = new Map(times.map((t, i) => [t, i]));
  const columns = [times];
  for (const r of results) {
    for (const key of ["mean", "min", "max"]) {
      const col = new Array(times.length).fill(null);
      r.t.forEach((t, i) => { col[index.get(t)] = r[key][i] * scale; });
      columns.push(col);
    }
  }
  return columns;
}

function draw(fields, data, unit) {
  const series = [{ value: (u, v) => (v == null ? "—" : formatTime(v, { label: true })) }];
  const bands = [];
  fields.forEach((name, i) => {
    const color = COLORS[i % COLORS.length];
    const base = series.length;
    series.push({ label: name, stroke: color, width: 1.5, spanGaps: false, value: (u, v) => v == null ? "—" : `${v.toFixed(3)} ${unit}`.trim() });
    series.push({ label: `${name} min`, stroke: "transparent", show: true, points: { show: false } });
    series.push({ label: `${name} max`, stroke: "transparent", show: true, points: { show: false } });
    bands.push({ series: [base + 2, base + 1], fill: color + "22" });
  });
  if (chart) chart.destroy();
  const el = $("chart");
  chart = new uPlot({
    width: el.clientWidth || 800, height: 360, series, bands,
    scales: { x: { time: true } },
    axes: [{ label: `time (${zone}, ${zoneLabel()})`, values: timeTicks, space: 70 }, { label: valueLabel(fields, unit) }],
    tzDate: (ts) => uPlot.tzDate(new Date(ts * 1e3), zone),
    legend: { live: true },
    // A drag selects a stretch; we fetch finer buckets for it rather than stretch the coarse ones.
    cursor: { drag: { x: true, y: false, setScale: false } },
    hooks: { setSelect: [onSelect] },
  }, data, el);
  selectByTouch(chart);
}

// uPlot selects with a mouse only: a finger dragging sideways across the plot selects the same
// way (the plot lets the browser pan vertically only, so a vertical swipe still scrolls the page).
function selectByTouch(u) {
  const over = u.over;
  let from = null;
  const at = (e) => Math.min(Math.max(e.clientX - over.getBoundingClientRect().left, 0), over.clientWidth);
  const select = (to, fire) => u.setSelect(
    { left: Math.min(from, to), width: Math.abs(to - from), top: 0, height: over.clientHeight }, fire);
  over.addEventListener("pointerdown", (e) => {
    if (e.pointerType === "mouse") return;
    from = at(e);
    over.setPointerCapture(e.pointerId);
  });
  over.addEventListener("pointermove", (e) => { if (from !== null && e.pointerType !== "mouse") select(at(e), false); });
  over.addEventListener("pointerup", (e) => {
    if (from === null || e.pointerType === "mouse") return;
    select(at(e), true);
    from = null;
  });
  over.addEventListener("pointercancel", () => {
    if (from === null) return;
    from = null;
    u.setSelect({ left: 0, top: 0, width: 0, height: 0 }, false);
  });
}

function onSelect(u) {
  if (u.select.width < 4 || !shown) return;
  const start = u.posToVal(u.select.left, "x");
  const end = u.posToVal(u.select.left + u.select.width, "x");
  u.setSelect({ left: 0, top: 0, width: 0, height: 0 }, false);
  zoomTo(start, end);
}

async function fetchSeries(topic, fields, r, scale) {
  const results = await Promise.all(fields.map((f) => getJSON(seriesURL(topic, f, r))));
  return { results, data: align(results, scale), points: results.reduce((acc, x) => acc + x.t.length, 0) };
}

function describe(topic, results) {
  const samples = results[0].count.reduce((a, b) => a + b, 0);
  return `${topic}: ${samples} samples in ${results[0].t.length} buckets of ${results[0].bucket_s} s`;
}

async function zoomTo(start, end) {
  const { topic, fields, opts } = shown;
  try {
    const { results, data, points } = await fetchSeries(topic, fields, { start, end }, opts.scale ?? 1);
    if (!points) { notify("Nothing was recorded in that stretch.", "warn"); return; }
    chart.setData(data, false);
    chart.setScale("x", { min: start, max: end });
    $("zoom-out").hidden = false;
    $("plot-info").textContent = `${describe(topic, results)} (zoomed)`;
  } catch (err) {
    notify(err.message, "error");
  }
}

async function plot(topic, fields, opts = {}) {
  // A preset says its unit; otherwise the server knows the field's (battery in %, not 0.72).
  const known = config.topics.find((t) => t.topic === topic)?.units?.[fields[0]];
  const scale = opts.scale ?? known?.scale ?? 1;
  const unit = opts.unit || known?.unit || "";
  opts = { ...opts, scale, unit };
  showView("chart");
  if (chart) { chart.destroy(); chart = null; }
  const r = range();
  $("plot-info").textContent = "Loading…";
  try {
    const { results, data, points } = await fetchSeries(topic, fields, r, scale);
    if (!points) {
      $("plot-info").textContent = `No recorded samples of ${topic} in this range.`;
      return;
    }
    draw(fields, data, unit);
    shown = { topic, fields, opts };
    $("plot-info").textContent = describe(topic, results);
  } catch (err) {
    $("plot-info").textContent = "";
    notify(err.message, "error");
  }
}

// A message as table cells: its leaves by dotted path (headers left out, arrays as JSON).
function flatten(msg, prefix = "", out = {}) {
  for (const [key, value] of Object.entries(msg ?? {})) {
    if (key === "header") continue;
    if (value && typeof value === "object" && !Array.isArray(value)) flatten(value, `${prefix}${key}.`, out);
    else out[`${prefix}${key}`] = Array.isArray(value) ? JSON.stringify(value) : String(value);
  }
  return out;
}

function cell(tag, text) {
  const el = document.createElement(tag);
  el.textContent = text;
  return el;
}

async function messages(topic) {
  showView("messages");
  $("messages-head").replaceChildren();
  $("messages-rows").replaceChildren();
  $("plot-info").textContent = "Loading…";
  try {
    const r = range();
    const q = new URLSearchParams({ topic, start: r.start, end: r.end, limit: MESSAGES_LIMIT });
    const data = await getJSON(`${config.urls.messages}?${q}`);
    const rows = data.messages.map((m) => ({ t: m.t, cells: flatten(m.data) }));
    const columns = [...new Set(rows.flatMap((row) => Object.keys(row.cells)))];
    $("messages-head").replaceChildren(cell("th", `Time (${zoneLabel()})`), ...columns.map((c) => cell("th", c)));
    $("messages-rows").replaceChildren(...rows.map((row) => {
      const tr = document.createElement("tr");
      tr.append(cell("td", formatTime(row.t)), ...columns.map((c) => cell("td", row.cells[c] ?? "")));
      return tr;
    }));
    $("plot-info").textContent = rows.length
      ? `${topic}: ${rows.length} messages, newest first${data.truncated ? ` (the newest ${MESSAGES_LIMIT}; narrow the range for older ones)` : ""}`
      : `No recorded messages of ${topic} in this range.`;
  } catch (err) {
    $("plot-info").textContent = "";
    notify(err.message, "error");
  }
}

// The timeline of the chosen range, or of a stretch of it picked by a drag (zoomed).
async function timeline(r = range(), zoomed = false) {
  try {
    const data = await getJSON(`${config.urls.timeline}?${new URLSearchParams({ start: r.start, end: r.end })}`);
    showView("timeline");
    const parts = { bar: $("timeline-bar"), axisEl: $("timeline-axis"), detail: $("timeline-detail"),
      rows: $("timeline-rows"), caption: $("timeline-caption") };
    const { total, states } = renderTimeline(parts, data);
    $("zoom-out").hidden = !zoomed;
    $("plot-info").textContent = states.length
      ? `State machine, ${formatDuration(total)} recorded in this ${zoomed ? "stretch (zoomed)" : "range"}`
        + " (time without any recording is left out)"
      : `No recorded state changes in this ${zoomed ? "stretch" : "range"}.`;
  } catch (err) {
    notify(err.message, "error");
  }
}

function preset(name) {
  if (name === "timeline") {
    fillTopics(config.state_topic);
    return timeline();
  }
  const p = config.presets[name];
  $("range").value = p.range;
  $("custom-range").hidden = true;
  fillTopics(p.topic);
  fillFields(p.fields[0]);
  return plot(p.topic, p.fields, p);
}

function exportURL(format) {
  const r = range();
  return `${config.urls.export}?${new URLSearchParams({ topic: $("topic").value, start: r.start, end: r.end, format })}`;
}

$("topic").addEventListener("change", () => fillFields());
$("range").addEventListener("change", () => {
  const custom = $("range").value === "custom";
  $("custom-range").hidden = !custom;
  if (custom && !$("start").value) {
    const now = Date.now() / 1000;
    $("start").value = toSiteInput(now - 3600);
    $("end").value = toSiteInput(now);
  }
});
document.querySelectorAll("[data-zone-label]").forEach((el) => { el.textContent = `${zone} (${zoneLabel()})`; });
$("plot-form").addEventListener("submit", (ev) => {
  ev.preventDefault();
  const topic = $("topic").value;
  const field = $("field").value;
  if (!topic) { notify("Nothing recorded to show yet.", "warn"); return; }
  try {
    range();
  } catch (err) {
    notify(err.message, "warn");
    return;
  }
  if (field === TIMELINE) timeline();
  else if (field === TABLE || !field) messages(topic);
  else plot(topic, [field]);
});
$("zoom-out").addEventListener("click", () => {
  if (shown?.timeline) timeline();
  else if (shown) plot(shown.topic, shown.fields, shown.opts);
});
dragToZoom($("timeline-bar"), (start, end) => timeline({ start, end }, true));
document.querySelectorAll("[data-preset]").forEach((btn) => btn.addEventListener("click", () => preset(btn.dataset.preset)));
document.querySelectorAll("[data-format]").forEach((a) => a.addEventListener("click", (ev) => {
  ev.preventDefault();
  if (!$("topic").value) { notify("Pick a recorded topic first.", "warn"); return; }
  try { location.href = exportURL(a.dataset.format); } catch (err) { notify(err.message, "error"); }
}));
window.addEventListener("resize", () => chart && chart.setSize({ width: $("chart").clientWidth, height: 360 }));

fillTopics();
