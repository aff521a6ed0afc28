// The plots page: downsampled series from the history API drawn with uPlot
// (mean line, min/max band so spikes stay visible), presets, state timeline, exports.
import { getJSON, notify } from "./api.js";
import { readConfig } from "./config.js";
import { formatDuration } from "./time.js";

const config = readConfig("history-config");
const $ = (id) => document.getElementById(id);
const RANGES = { hour: 3600, day: 86400, week: 7 * 86400 };
const COLORS = ["#2563eb", "#dc2626", "#059669", "#d97706", "#7c3aed"];
let chart = null;

function fillTopics(selected) {
  const topics = $("topic");
  topics.replaceChildren(...config.topics.map((t) => new Option(`${t.topic} (${t.msg_type})`, t.topic)));
  if (selected) topics.value = selected;
  fillFields();
}

function fillFields(selected) {
  const topic = config.topics.find((t) => t.topic === $("topic").value);
  const fields = topic ? topic.fields : [];
  $("field").replaceChildren(...fields.map((f) => new Option(f, f)));
  if (selected && fields.includes(selected)) $("field").value = selected;
}

function range() {
  const choice = $("range").value;
  if (choice === "custom") {
    const start = Date.parse($("start").value) / 1000;
    const end = Date.parse($("end").value) / 1000;
    if (!isFinite(start) || !isFinite(end) || start >= end) throw new Error("Pick a start before the end.");
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
  const series = [{}];
  const bands = [];
  fields.forEach((name, i) => {
    const color = COLORS[i % COLORS.length];
    const base = series.length;
    series.push({ label: name, stroke: color, width: 1.5, spanGaps: false, value: (u, v) => v == null ? "—" : `${v.toFixed(3)}${unit}` });
    series.push({ label: `${name} min`, stroke: "transparent", show: true, points: { show: false } });
    series.push({ label: `${name} max`, stroke: "transparent", show: true, points: { show: false } });
    bands.push({ series: [base + 2, base + 1], fill: color + "22" });
  });
  if (chart) chart.destroy();
  const el = $("chart");
  chart = new uPlot({
    width: el.clientWidth || 800, height: 360, series, bands,
    scales: { x: { time: true } }, axes: [{}, { label: unit || undefined }],
    legend: { live: true },
  }, data, el);
}

async function plot(topic, fields, { scale = 1, unit = "" } = {}) {
  $("timeline").hidden = true;
  $("chart").hidden = false;
  const r = range();
  $("plot-info").textContent = "Loading…";
  try {
    const results = await Promise.all(fields.map((f) => getJSON(seriesURL(topic, f, r))));
    const n = results.reduce((acc, x) => acc + x.t.length, 0);
    if (!n) {
      if (chart) { chart.destroy(); chart = null; }
      $("plot-info").textContent = `No recorded samples of ${topic} in this range.`;
      return;
    }
    draw(fields, align(results, scale), unit);
    const samples = results[0].count.reduce((a, b) => a + b, 0);
    $("plot-info").textContent = `${topic}: ${samples} samples in ${results[0].t.length} buckets of ${results[0].bucket_s} s`;
  } catch (err) {
    $("plot-info").textContent = "";
    notify(err.message, "error");
  }
}

async function timeline() {
  const r = range();
  try {
    const data = await getJSON(`${config.urls.timeline}?${new URLSearchParams(r)}`);
    if (chart) { chart.destroy(); chart = null; }
    $("chart").hidden = true;
    $("timeline").hidden = false;
    const total = Object.values(data.totals).reduce((a, b) => a + b, 0);
    const states = Object.keys(data.totals).sort((a, b) => data.totals[b] - data.totals[a]);
    const color = (state) => COLORS[states.indexOf(state) % COLORS.length];
    $("timeline-bar").replaceChildren(...data.segments.map((seg) => {
      const div = document.createElement("div");
      div.className = "timeline-seg";
      div.style.flexGrow = String(seg.end - seg.start);
      div.style.background = color(seg.state);
      div.title = `${seg.state}: ${formatDuration(seg.end - seg.start)}`;
      return div;
    }));
    $("timeline-rows").replaceChildren(...states.map((state) => {
      const tr = document.createElement("tr");
      const share = total ? (100 * data.totals[state]) / total : 0;
      for (const text of [state, formatDuration(data.totals[state]), `${share.toFixed(1)} %`]) {
        const td = document.createElement("td");
        td.textContent = text;
        tr.append(td);
      }
      tr.firstChild.style.borderLeft = `6px solid ${color(state)}`;
      return tr;
    }));
    $("plot-info").textContent = states.length ? `State machine, ${formatDuration(total)} covered` : "No recorded state changes in this range.";
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
$("range").addEventListener("change", () => { $("custom-range").hidden = $("range").value !== "custom"; });
$("plot-form").addEventListener("submit", (ev) => {
  ev.preventDefault();
  if (!$("topic").value || !$("field").value) { notify("Pick a recorded topic and a numeric field.", "warn"); return; }
  plot($("topic").value, [$("field").value]);
});
document.querySelectorAll("[data-preset]").forEach((btn) => btn.addEventListener("click", () => preset(btn.dataset.preset)));
document.querySelectorAll("[data-format]").forEach((a) => a.addEventListener("click", (ev) => {
  ev.preventDefault();
  if (!$("topic").value) { notify("Pick a recorded topic first.", "warn"); return; }
  try { location.href = exportURL(a.dataset.format); } catch (err) { notify(err.message, "error"); }
}));
window.addEventListener("resize", () => chart && chart.setSize({ width: $("chart").clientWidth, height: 360 }));

fillTopics();
