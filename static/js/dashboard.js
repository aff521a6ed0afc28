// The dashboard: live cards, the robot log, and the command cards (alerts: the header's strip, alert-strip.js).
import { notify } from "./api.js";
import { initAudio } from "./audio.js";
import { initCommands } from "./commands.js";
import { readConfig } from "./config.js";
import { heading, linkState } from "./linkstate.js";
import { live } from "./live.js";
import { SensorsCard } from "./sensors.js";
import { formatAge, formatTime } from "./time.js";

const config = readConfig("live-config");
const latest = {}; // key -> {msg, t}
const field = (name) => document.querySelectorAll(`[data-field="${name}"]`);
const set = (name, text) => field(name).forEach((el) => { el.textContent = text; });

const renderers = {
  battery_soc(m) {
    const pct = Math.round(m.data * 1000) / 10;
    set("battery.percent", `${pct.toFixed(1)} %`);
    field("battery.meter").forEach((el) => { el.value = pct; });
  },
  battery_voltage(m) { set("battery.voltage", `${m.data.toFixed(2)} V`); },
  battery_recharge_state(m) {
    const name = config.recharge_states[m.data] ?? (m.data > 0 ? "charging" : "error");
    set("battery.charging", m.data < -1 ? `error (${m.data})` : name);
  },
  motors_state(m) { set("motors.state", m.data ? "enabled" : "disabled"); },
  // The mode the server was asked for and how far it got; the robot's own echo only when
  // no request went through this server (with the server strategy the echo stays empty).
  mode_request(m) {
    const status = { running: "applying…", reached: "reached", failed: "failed" }[m.status] ?? m.status;
    set("mode.requested", `${m.mode} · ${status}`);
  },
  robot_mode(m) { if (!latest.mode_request) set("mode.requested", m.data || "—"); },
  at_location(m) { set("location.current", m.name || "(none)"); },
  smach_status(m) {
    smachActive[m.path] = m.active_states || [];
    set("smach.active", smachChain().join(" › ") || "—");
    renderHeadline();
  },
  state_change(m) {
    set("smach.previous", m.from_system_state || "—");
    set("smach.event", m.event || "—");
    renderHeadline();
  },
  emotional_state(m) {
    set("emotion.name", m.to_emotional_state);
    const pad = { P: m.current_pleasure, A: m.current_arousal, D: m.current_dominance };
    for (const [dim, v] of Object.entries(pad)) {
      document.querySelectorAll(`[data-pad="${dim}"]`).forEach((el) => {
        el.style.left = v < 0 ? `${50 + 50 * v}%` : "50%";
        el.style.width = `${Math.abs(50 * v)}%`;
        el.classList.toggle("neg", v < 0);
      });
      document.querySelectorAll(`[data-pad-value="${dim}"]`).forEach((el) => { el.textContent = v.toFixed(2); });
    }
  },
  emotion_system_status(m) { set("emotion.system", m.data ? "system on" : "system off"); },
  text_to_speech(m) { set("tts.last", m.data); },
  tts_feedback(m) { set("tts.feedback", m.data); },
  rosout(m, t) { logLine(m, t); },
  bumper_state(m) {
    sensors.showBumpers(m);
  },
  overlay_sonar(m) { sensors.showSonar(m); },
  diagnostics_summary(m) {
    sensors.showDiagnostics(m);
  },
};

// SMACH introspection: each container reports its active states; the chain from the
// top container down names where the robot is even before the next transition.
const smachActive = {};
function smachChain() {
  const chain = [];
  for (const path of Object.keys(smachActive).sort((a, b) => a.length - b.length)) {
    const parent = chain[chain.length - 1];
    if (!chain.length || path.endsWith(`/${parent}`)) {
      const active = smachActive[path][0];
      if (active) chain.push(active);
    }
  }
  return chain;
}

// The headline is the newer of the last transition and the introspection's active state:
// after a robot restart the store still holds the transition from before it.
function renderHeadline() {
  const change = latest.state_change, status = latest.smach_status;
  const chain = smachChain();
  const fromStatus = status && chain.length && (!change || status.t >= change.t);
  set("smach.current", fromStatus ? chain[chain.length - 1] : (change?.msg.to_system_state ?? "—"));
}

const sensors = new SensorsCard(document.getElementById("card-sensors"));

// --- log console -----------------------------------------------------------------------
const logBox = document.getElementById("log");
const levelSelect = document.getElementById("log-level");
const pauseBtn = document.getElementById("log-pause");
const held = [];
let paused = false;
const MAX_LINES = 500;

// When the line was logged: the robot's stamp, or when the server received it.
function stampOf(m, t) {
  const s = m.header?.stamp;
  return s && s.secs ? s.secs + s.nsecs / 1e9 : t;
}

function logLine(m, t) {
  m.at = stampOf(m, t);
  if (paused) { held.push(m); document.getElementById("log-held").textContent = `${held.length} new lines held while paused`; return; }
  appendLine(m);
}

function appendLine(m) {
  const row = document.createElement("div");
  const levelName = config.log_levels[m.level] || String(m.level);
  row.className = `log-line log-${levelName.toLowerCase()}`;
  row.dataset.level = m.level;
  row.textContent = `${formatTime(m.at)} [${levelName}] ${m.name}: ${m.msg}`;
  row.hidden = m.level < Number(levelSelect.value);
  const atBottom = logBox.scrollTop + logBox.clientHeight >= logBox.scrollHeight - 4;
  logBox.append(row);
  while (logBox.childElementCount > MAX_LINES) logBox.firstElementChild.remove();
  if (atBottom) logBox.scrollTop = logBox.scrollHeight;
}

levelSelect.addEventListener("change", () => {
  const min = Number(levelSelect.value);
  logBox.querySelectorAll(".log-line").forEach((row) => { row.hidden = Number(row.dataset.level) < min; });
});
pauseBtn.addEventListener("click", () => {
  paused = !paused;
  pauseBtn.textContent = paused ? "Resume" : "Pause";
  pauseBtn.setAttribute("aria-pressed", String(paused));
  if (!paused) { held.splice(0).forEach(appendLine); document.getElementById("log-held").textContent = ""; }
});
document.getElementById("log-clear").addEventListener("click", () => {
  logBox.replaceChildren();
  held.length = 0;
  document.getElementById("log-held").textContent = "";
});

// --- connection card and ages ----------------------------------------------------------
// The robot dials in (UPLINK): from where and since when, or what is missing.
function uplinkText(u) {
  const at = (t) => formatTime(t, { label: true });
  if (u.connected) return `robot connected through its uplink from ${u.address} since ${at(u.since)}`;
  if (u.last_address) return `no uplink from the robot: the last, from ${u.last_address}, ended ${at(u.ended)} (${u.why || "closed"})`;
  return u.why || "no uplink from the robot yet: is its uplink agent running?";
}

function renderStatus(s) {
  const state = linkState(s);
  set("link.state", heading(state));
  if (s.server_down) set("link.detail", state.why);
  else {
    const since = s.since ? formatAge(Date.now() / 1000 - s.since) : "";
    set("link.detail", state.why || (s.connected ? `connected ${since}` : `retrying${s.attempts ? ` (attempt ${s.attempts})` : ""}`));
    if (s.url) set("link.url", s.uplink ? uplinkText(s.uplink) : s.url);
    if (s.ros) set("link.ros", `ROS ${s.ros}`);
  }
  document.getElementById("card-connection").classList.toggle("bad", !state.ok);
}

function tickAges() {
  const now = Date.now() / 1000;
  document.querySelectorAll("[data-age]").forEach((el) => {
    const entry = latest[el.dataset.age];
    const age = entry ? now - entry.t : null;
    el.textContent = entry ? `updated ${formatAge(age)}` : "no data yet";
    el.closest(".card")?.classList.toggle("stale", !entry || age > config.stale_after_s);
  });
}
setInterval(tickAges, 1000);

live.watch(config.keys, (frame) => {
  latest[frame.key] = frame;
  try { renderers[frame.key]?.(frame.msg, frame.t); } catch (e) { console.error("render", frame.key, e); }
  tickAges();
});
live.onStatus(renderStatus);
document.getElementById("reconnect-btn")?.addEventListener("click", () => {
  live.send({ action: "reconnect" });
  notify("Asking the link to reconnect…");
});
tickAges();
initCommands(document);
initAudio(document.getElementById("audio"), config);
