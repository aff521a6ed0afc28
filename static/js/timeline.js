// The state-machine timeline: one bar on a time axis (the site's zone, 24-hour), each state in a
// colour of its own (no two states share one), a tooltip and a tap readout per stretch, and a table
// of time, share and how often each state was entered; a sideways drag across it zooms, as on the plots.
import { formatDuration, formatTime, zoneLabel } from "./time.js";

// The robot's states (ROBOT_INTERFACE.md) keep their colour from one view to the next.
const STATE_COLORS = {
  offline: "#9ca3af", startup: "#0ea5e9", suspension: "#1d4ed8", demo: "#dc2626", manual: "#ea580c",
  behaviour: "#16a34a", idle: "#65a30d", navigation: "#0d9488", navigation_planning: "#14b8a6",
  navigation_go_to_emotional: "#0f766e", navigation_go_to_schedular: "#2dd4bf", wandering_emotional: "#115e59",
  show_off_mea: "#c026d3", conveying_emotional_state: "#db2777", music_horror: "#7c3aed",
  astrolanguage: "#4f46e5", waking_up: "#eab308", sleepy: "#a16207", sleeping: "#1e293b", exhausted: "#78350f",
};
// For states the robot may add later: none of the colours above.
const SPARE = ["#be123c", "#0369a1", "#4d7c0f", "#9333ea", "#b45309", "#475569", "#e11d48", "#0891b2"];

export function stateColors(states) {
  const used = new Set(Object.values(STATE_COLORS));
  const spare = SPARE.filter((c) => !used.has(c));
  const out = {};
  let next = 0;
  for (const state of states) out[state] = STATE_COLORS[state] ?? spare[next++ % spare.length];
  return out;
}

// Tick step (s) for about `count` ticks over `span` seconds.
const STEPS = [1, 2, 5, 10, 15, 30, 60, 120, 300, 600, 900, 1800, 3600, 7200, 10800, 21600, 43200, 86400];
function tickStep(span, count) {
  return STEPS.find((s) => span / s <= count) ?? 86400 * Math.ceil(span / count / 86400);
}

// The site zone's offset from UTC at t (s): ticks fall on whole minutes and hours of the site's clock.
function zoneOffset(t) {
  const m = /^(\d{4})-(\d{2})-(\d{2}) (\d{2}):(\d{2}):(\d{2})$/.exec(formatTime(t));
  return Date.UTC(+m[1], m[2] - 1, +m[3], +m[4], +m[5], +m[6]) / 1000 - Math.floor(t);
}

function axis(el, start, end) {
  const span = end - start;
  const step = tickStep(span, Math.max(2, Math.floor(el.clientWidth / 110)));
  const offset = zoneOffset(start);
  const ticks = [];
  for (let t = Math.ceil((start + offset) / step) * step - offset; t <= end; t += step) ticks.push(t);
  // The date on the first tick and wherever the day changes.
  let day = formatTime(start).slice(0, 10);
  el.replaceChildren(...ticks.map((t, i) => {
    const tick = document.createElement("span");
    tick.className = "timeline-tick";
    tick.style.left = `${(100 * (t - start)) / span}%`;
    const today = formatTime(t).slice(0, 10);
    tick.textContent = formatTime(t, { date: i === 0 || today !== day, seconds: step < 60 });
    day = today;
    return tick;
  }));
  // Each label stays inside the axis (a date makes one wide, and the day may change at either end);
  // its mark stays on its time.
  // Measured all at once, then moved: one layout, not one per label.
  const width = el.getBoundingClientRect().width;
  const labels = [...el.children].map((tick) => [tick, tick.getBoundingClientRect().width]);
  for (const [tick, w] of labels) {
    const x = (width * parseFloat(tick.style.left)) / 100;
    const shift = Math.min(Math.max(-w / 2, -x), width - x - w);
    tick.style.transform = `translateX(${shift}px)`;
    tick.style.setProperty("--mark", `${-shift}px`);
  }
}

export function renderTimeline({ bar, axisEl, detail, rows, caption }, data) {
  const span = data.end - data.start;
  const total = Object.values(data.totals).reduce((a, b) => a + b, 0);
  const states = Object.keys(data.totals).sort((a, b) => data.totals[b] - data.totals[a]);
  const colors = stateColors(states);
  bar.dataset.start = String(data.start);
  bar.dataset.end = String(data.end);
  const describe = (seg) => `${seg.state}: ${formatTime(seg.start)} – ${formatTime(seg.end, { date: false })}`
    + ` ${zoneLabel(seg.start)} (${formatDuration(seg.end - seg.start)})`;
  bar.replaceChildren(...data.segments.map((seg) => {
    const div = document.createElement("div");
    div.className = "timeline-seg";
    div.dataset.state = seg.state;
    div.style.left = `${(100 * (seg.start - data.start)) / span}%`;
    div.style.width = `${(100 * (seg.end - seg.start)) / span}%`;
    div.style.background = colors[seg.state];
    div.title = describe(seg);
    div.addEventListener("click", () => { detail.textContent = describe(seg); });
    return div;
  }));
  axis(axisEl, data.start, data.end);
  detail.textContent = "";
  caption.textContent = `Times in ${zoneLabel(data.end)}; tap a stretch for its times.`;
  rows.replaceChildren(...states.map((state) => {
    const tr = document.createElement("tr");
    const share = total ? (100 * data.totals[state]) / total : 0;
    const count = data.counts?.[state] ?? 0;
    for (const text of [state, formatDuration(data.totals[state]), `${share.toFixed(1)} %`, String(count)]) {
      const td = document.createElement("td");
      td.textContent = text;
      tr.append(td);
    }
    const swatch = document.createElement("span");
    swatch.className = "timeline-swatch";
    swatch.style.background = colors[state];
    tr.firstChild.prepend(swatch);
    return tr;
  }));
  return { total, states };
}

// A sideways drag across the bar (mouse or finger, as on the plots) picks a stretch of the range drawn:
// onPick(start, end). A tap stays a stretch's readout.
export function dragToZoom(bar, onPick) {
  const mark = document.createElement("div");
  mark.className = "timeline-select";
  let from = null;
  const at = (e) => {
    const box = bar.getBoundingClientRect();
    return Math.min(Math.max(e.clientX - box.left, 0), box.width);
  };
  const show = (to) => {
    mark.style.left = `${Math.min(from, to)}px`;
    mark.style.width = `${Math.abs(to - from)}px`;
  };
  const end = (e) => {
    window.removeEventListener("pointermove", move);
    window.removeEventListener("pointerup", end);
    window.removeEventListener("pointercancel", end);
    mark.remove();
    const to = e.type === "pointerup" ? at(e) : from;
    const [lo, hi] = [Math.min(from, to), Math.max(from, to)];
    const width = bar.getBoundingClientRect().width;
    from = null;
    if (hi - lo < 4 || !width) return;
    const start = Number(bar.dataset.start), span = Number(bar.dataset.end) - start;
    onPick(start + (span * lo) / width, start + (span * hi) / width);
  };
  const move = (e) => show(at(e));
  bar.addEventListener("pointerdown", (e) => {
    if (e.button > 0 || !bar.dataset.end) return;
    from = at(e);
    show(from);
    bar.append(mark);
    window.addEventListener("pointermove", move);
    window.addEventListener("pointerup", end);
    window.addEventListener("pointercancel", end);
  });
}
