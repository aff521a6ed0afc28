// The replay page: seek (the state at t plus the window after it), then play through the window
// at the chosen speed, fetching the next window before this one runs out. Nothing here commands the robot.
import { request } from "../api.js";
import { formatTime, parseSiteTime } from "../time.js";
import { drawMap } from "./map.js";
import { Timeline } from "./timeline.js";

const WINDOW_S = 60;
const config = JSON.parse(document.getElementById("replay-config").textContent);
const $ = (id) => document.getElementById(id);
const scrubber = $("scrubber"), playButton = $("play"), speedSelect = $("speed");
const canvas = $("replay-map"), frameImg = $("replay-frame");

let range = { start: config.start, end: config.end };
let t = config.t;
let timeline = null, seeking = null, extending = null, playing = false, lastTick = 0, seekId = 0;
// Read by the browser tests and bench/replay.py: renders, and the seeks that reached the page.
window.replayStats = { renders: 0, seeks: 0, frames: 0, t: 0 };

const fmt = (s) => formatTime(s, { label: true });
const clock = (s) => formatTime(s, { date: false });
const siteInput = (s) => formatTime(s);

function text(id, value) { const el = $(id); if (el.textContent !== value) el.textContent = value; }

function rows(tbody, items, cells) {
  const key = items.map((i) => `${i.t}|${i.id || ""}`).join(",");
  if (tbody.dataset.key === key) return;
  tbody.dataset.key = key;
  tbody.replaceChildren(...items.slice().reverse().map((item) => {
    const tr = document.createElement("tr");
    for (const value of cells(item)) { const td = document.createElement("td"); td.textContent = value; tr.append(td); }
    return tr;
  }));
}

function render(moment) {
  window.replayStats.renders += 1;
  window.replayStats.t = moment.t;
  const m = moment.topics, msg = (k) => (m[k] ? m[k].msg : null);
  const time = $("replay-time");
  time.dataset.t = moment.t.toFixed(3);
  text("replay-time", fmt(moment.t));
  scrubber.value = String(Math.round(((moment.t - range.start) / (range.end - range.start)) * 1000));
  text("r-state", msg("state_change") ? msg("state_change").to_system_state : "—");
  const request = msg("mode_request"), reached = msg("mode_reached");
  text("r-mode", request ? `${request.mode}${request.by ? ` by ${request.by}` : ""}${request.ok ? "" : " · failed"}` : "—");
  text("r-mode-reached", reachedText(reached, request));
  const emotion = msg("emotional_state");
  text("r-emotion", emotion ? emotion.to_emotional_state || emotion.emotional_state || JSON.stringify(emotion).slice(0, 60) : "—");
  text("r-battery", msg("battery_soc") ? `${Math.round(msg("battery_soc").data * 100)} %` : "—");
  text("r-motors", msg("motors_state") ? (msg("motors_state").data ? "on" : "off") : "—");
  const bump = msg("bumper_state");
  text("r-bumpers", bump ? ([...(bump.front_bumpers || []), ...(bump.rear_bumpers || [])].some(Boolean) ? "pressed" : "clear") : "—");
  text("r-goal", moment.goal ? `x ${moment.goal.x.toFixed(2)}, y ${moment.goal.y.toFixed(2)}` : "—");
  text("r-location", msg("current_location") ? msg("current_location").data : "—");
  text("r-pose", moment.pose ? `x ${moment.pose[1].toFixed(2)}, y ${moment.pose[2].toFixed(2)}` : "—");
  drawMap(canvas, moment, () => timeline && render(timeline.at(t)));
  if (moment.frame) {
    if (frameImg.dataset.id !== String(moment.frame.id)) {
      frameImg.dataset.id = String(moment.frame.id);
      frameImg.dataset.t = moment.frame.t.toFixed(3);
      frameImg.src = moment.frame.url;
      window.replayStats.frames += 1;
    }
    text("frame-note", `frame of ${clock(moment.frame.t)}`);
  } else {
    frameImg.removeAttribute("src"); frameImg.dataset.id = ""; frameImg.dataset.t = "";
    text("frame-note", "no camera frame recorded at this moment");
  }
  rows($("r-log"), moment.log, (l) => [clock(l.t), l.level, l.name, l.msg]);
  rows($("r-commands"), moment.commands, (c) => [clock(c.t), c.who, c.action, c.ok ? "ok" : c.outcome || "failed"]);
}

// The mode whose state the robot was in (its state named when it differs), ticked when it is the one requested.
function reachedText(reached, request) {
  if (!reached || !reached.state) return "—";
  if (!reached.mode) return `none (${reached.state})`;
  const named = reached.state === reached.mode ? reached.mode : `${reached.mode} (${reached.state})`;
  return request && request.mode === reached.mode ? `${named} ✓` : named;
}

async function seek(to) {
  t = Math.min(Math.max(to, range.start), range.end);
  const id = ++seekId;
  const q = (params) => new URLSearchParams(params).toString();
  seeking = Promise.all([
    request("GET", `${config.urls.state}?${q({ t })}`),
    request("GET", `${config.urls.window}?${q({ start: t, end: Math.min(t + WINDOW_S, range.end + 1) })}`),
  ]);
  const [state, win] = await seeking;
  if (id !== seekId) return;  // a later seek overtook this one
  seeking = null;
  timeline = new Timeline(state, win);
  window.replayStats.seeks += 1;
  render(timeline.at(t));
}

async function extend() {
  if (extending || !timeline || timeline.end >= range.end) return;
  const from = timeline.end, id = seekId;
  extending = request("GET", `${config.urls.window}?${new URLSearchParams({ start: from, end: Math.min(from + WINDOW_S, range.end + 1) })}`);
  try {
    const win = await extending;
    if (id === seekId && timeline) timeline.extend(win);
  } finally { extending = null; }
}

function tick(now) {
  if (!playing) return;
  const dt = Math.min(0.25, (now - lastTick) / 1000);
  lastTick = now;
  if (timeline && !seeking) {
    t += dt * Number(speedSelect.value);
    if (t >= range.end) { t = range.end; setPlaying(false); }
    if (timeline.end - t < 30 * Number(speedSelect.value)) extend();
    if (timeline.covers(t)) render(timeline.at(t));
    else if (!extending) seek(t);
  }
  requestAnimationFrame(tick);
}

function setPlaying(on) {
  playing = on;
  playButton.textContent = on ? "Pause" : "Play";
  playButton.setAttribute("aria-pressed", String(on));
  if (on) { lastTick = performance.now(); requestAnimationFrame(tick); }
}

playButton.addEventListener("click", () => setPlaying(!playing));
$("step-back").addEventListener("click", () => { setPlaying(false); seek(t - 1); });
$("step-forward").addEventListener("click", () => {
  setPlaying(false);
  if (timeline && timeline.covers(t + 1)) { t += 1; render(timeline.at(t)); } else seek(t + 1);
});
scrubber.addEventListener("input", () => seek(range.start + (Number(scrubber.value) / 1000) * (range.end - range.start)));

const incidentSelect = $("incident");
for (const i of config.incidents) {
  const option = new Option(`${fmt(i.t)} · ${i.label}`, String(i.id));
  option.selected = i.id === config.incident;
  incidentSelect.append(option);
}
incidentSelect.addEventListener("change", () => {
  if (incidentSelect.value) window.location.search = `?incident=${incidentSelect.value}`;
});
$("range-start").value = siteInput(range.start);
$("range-end").value = siteInput(range.end);
$("replay-range").addEventListener("submit", (event) => {
  event.preventDefault();
  const start = parseSiteTime($("range-start").value), end = parseSiteTime($("range-end").value);
  if (!(end > start)) { text("replay-status", "To must come after From"); return; }
  range = { start, end };
  setPlaying(false);
  seek(start);
});

seek(t);
