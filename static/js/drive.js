// The manual control page: keyboard and joystick → the teleop socket, camera via the server's
// proxy, commanded and measured velocity. The server does the rate, the clamping and the
// deadman; this page only says what the operator's hands are doing, ~20 times a second.
import { create as createStick } from "../vendor/nipplejs/index.mjs";
import { notify } from "./api.js";
import { initAudio } from "./audio.js";
import { initCommands } from "./commands.js";
import { readConfig, socketURL, toLogin } from "./config.js";
import { live } from "./live.js";
import { formatAge } from "./time.js";

const config = readConfig("drive-config");
const card = document.getElementById("drive");
const canDrive = card.dataset.canDrive === "true";
const canTakeover = card.dataset.canTakeover === "true";
const SEND_INTERVAL_MS = 50;
const UNAUTHENTICATED = 4401;
const ACCESS_CHANGED = 4403; // the server closed it: this person may no longer drive
const $ = (id) => document.getElementById(id);
const fmt = (v, digits = 2) => (Number.isFinite(v) ? v.toFixed(digits) : "—");

// --- live readouts -----------------------------------------------------------------------
function yawOf(q) { return Math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z)); }

function onUpdate(frame) {
  const m = frame.msg;
  if (frame.key === "odom") {
    const v = m.twist.twist.linear.x, w = m.twist.twist.angular.z;
    const el = $("odom-vel");
    el.dataset.linear = v; el.dataset.angular = w;
    el.textContent = `${fmt(v)} m/s · ${fmt(w)} rad/s`;
  } else if (frame.key === "robot_pose") {
    const el = $("pose");
    const yaw = yawOf(m.orientation);
    el.dataset.x = m.position.x; el.dataset.y = m.position.y; el.dataset.yaw = yaw;
    el.textContent = `x ${fmt(m.position.x)} · y ${fmt(m.position.y)} · ${fmt(yaw * 180 / Math.PI, 0)}°`;
  } else if (frame.key === "motors_state") {
    $("motors").textContent = m.data ? "enabled" : "disabled";
    motorsOff = m.data === false;
    renderLock();
  }
}
live.watch(config.keys, onUpdate);
live.onStatus((status) => {
  const online = !!status.connected;
  // Connected but silent (hung, frozen): "not responding", driving refused until it answers.
  const hung = !!status.robot_connected && status.responding === false;
  if (online === robotOnline && hung === robotHung) return;
  robotOnline = online;
  robotHung = hung;
  if (!online && sending) stopInput("release");
  renderLock();
});
// Mode buttons, speech box and motor button.
initCommands(document);
initAudio(document.getElementById("audio"), config);

// --- camera --------------------------------------------------------------------------------
// An MJPEG <img> fires "load" once, not once per frame, so a new frame is noticed when a small
// sample of the picture changes. No new frame for camera_stale_s: greyed out, "camera
// unavailable", and a fresh stream every few seconds until frames flow again.
const camera = $("camera");
const img = $("camera-img");
const placeholder = $("camera-placeholder");
const STALE_MS = config.camera_stale_s * 1000;
const RESTART_MS = 3000;
const sampler = document.createElement("canvas");
sampler.width = 64; sampler.height = 48;
const sampleCtx = sampler.getContext("2d", { willReadFrequently: true });
const frames = { lastAt: 0, lastHash: null, streamAt: 0 };
let retryTimer = null;

function startCamera() {
  clearInterval(retryTimer);
  frames.streamAt = Date.now();
  // No placeholder picture from the server: the page's own says it (never twice, one over the other).
  img.src = `${config.stream_url}?fallback=none&t=${Date.now()}`;
}

function pictureHash() {
  sampleCtx.drawImage(img, 0, 0, sampler.width, sampler.height);
  const data = sampleCtx.getImageData(0, 0, sampler.width, sampler.height).data;
  let h = 0;
  for (let i = 0; i < data.length; i += 1) h = (h * 31 + data[i]) | 0;
  return h;
}

function watchFrames() {
  const now = Date.now();
  if (!img.hidden && img.naturalWidth) {
    const h = pictureHash();
    if (h !== frames.lastHash) { frames.lastHash = h; frames.lastAt = now; }
  }
  const age = frames.lastAt ? now - frames.lastAt : null;
  const stale = age == null ? now - frames.streamAt > STALE_MS : age > STALE_MS;
  camera.dataset.state = stale ? "stale" : (age == null ? "connecting" : "live");
  camera.dataset.frameAge = age == null ? "" : (age / 1000).toFixed(1);
  $("camera-age").textContent = age == null ? (stale ? "no frame" : "connecting…")
    : stale ? `last frame ${formatAge(age / 1000)}` : `frame ${(age / 1000).toFixed(1)} s old`;
  if (stale) {
    placeholder.hidden = false;
    if (img.hidden) return; // the error handler counts down to its own retry
    $("camera-retry").textContent = age == null ? "Waiting for the first frame…" : `No new frame for ${Math.round(age / 1000)} s.`;
    if (now - frames.streamAt > RESTART_MS + STALE_MS) startCamera();
  } else if (!img.hidden) {
    placeholder.hidden = true;
  }
}

img.addEventListener("load", () => { img.hidden = false; });
img.addEventListener("error", () => {
  placeholder.hidden = false;
  img.hidden = true;
  let left = 3;
  $("camera-retry").textContent = `Retrying in ${left} s…`;
  clearInterval(retryTimer);
  retryTimer = setInterval(() => {
    left -= 1;
    if (left > 0) $("camera-retry").textContent = `Retrying in ${left} s…`;
    else startCamera();
  }, 1000);
});
startCamera();
setInterval(watchFrames, 250);

// --- teleop socket ----------------------------------------------------------------------
const lock = { holder: null, you: false };
let estop = null; // the E-STOP message while it is latched: no input is sent
let robotOnline = false;
let robotHung = false;
let motorsOff = false; // the robot says its motors are off: the server refuses moves, this says why
let ws = null;
let wsDelay = 500;
let lastError = { message: "", at: 0 };

function send(obj) {
  if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(obj));
}

function showError(message) {
  const now = Date.now();
  if (message === lastError.message && now - lastError.at < 3000) return;
  lastError = { message, at: now };
  notify(message, "error");
}

function renderLock() {
  const el = $("lock-state");
  el.dataset.holder = lock.holder || "";
  el.dataset.you = String(lock.you);
  el.textContent = estop ? `Stopped: ${estop}` : lock.you ? "You are driving"
    : lock.holder ? `${lock.holder} is driving` : "Nobody is driving";
  el.dataset.estop = String(!!estop);
  el.classList.toggle("lock-estop", !!estop);
  el.classList.toggle("lock-you", lock.you);
  el.classList.toggle("lock-other", !lock.you && !!lock.holder);
  card.classList.toggle("locked-out", !lock.you && !!lock.holder);
  card.classList.toggle("robot-offline", !robotOnline);
  $("drive-offline").hidden = robotOnline;
  const motorsNote = $("motors-off");
  if (motorsNote) motorsNote.hidden = !(motorsOff && robotOnline);
  $("drive-offline").textContent = robotHung
    ? "The robot is not responding: driving is disabled until it answers."
    : "The robot is offline: driving is disabled until it is back.";
  const show = (id, on) => { const b = $(id); if (b) b.hidden = !on; };
  show("lock-acquire", canDrive && robotOnline && !estop && !lock.you && !lock.holder);
  show("lock-release", lock.you);
  show("lock-takeover", canTakeover && robotOnline && !lock.you && !!lock.holder);
}

function setCommanded(linear, angular) {
  const el = $("cmd-vel");
  el.dataset.linear = linear; el.dataset.angular = angular;
  el.textContent = `${fmt(linear)} m/s · ${fmt(angular)} rad/s`;
}

// An E-STOP stops this page's input at once, whatever the hands still do, and says why.
function onEstop(frame) {
  estop = frame.latched ? frame.message : null;
  if (estop) {
    keys.clear();
    Object.assign(stick, { active: false, x: 0, y: 0 });
    stopInput("release");
    setCommanded(0, 0);
  }
  renderLock();
}

function openSocket() {
  ws = new WebSocket(socketURL(config.teleop_socket));
  ws.onopen = () => { wsDelay = 500; card.classList.remove("offline"); };
  ws.onmessage = (ev) => {
    const frame = JSON.parse(ev.data);
    if (frame.type === "lock") { Object.assign(lock, { holder: frame.holder, you: frame.you }); renderLock(); }
    else if (frame.type === "commanded") setCommanded(frame.linear, frame.angular);
    else if (frame.type === "estop") onEstop(frame);
    else if (frame.type === "error") showError(frame.message);
    else if (frame.type === "notice") notify(frame.message, "warn");
  };
  ws.onclose = (ev) => {
    card.classList.add("offline");
    Object.assign(lock, { holder: null, you: false });
    renderLock();
    $("lock-state").textContent = "Drive connection lost — reconnecting…";
    if (ev.code === UNAUTHENTICATED) { toLogin(); return; }
    if (ev.code === ACCESS_CHANGED) showError("Your access has changed: you may no longer drive the robot.");
    setTimeout(openSocket, wsDelay);
    wsDelay = Math.min(wsDelay * 2, 8000);
  };
}
openSocket();

// --- input -------------------------------------------------------------------------------
const keys = new Set();
const stick = { active: false, x: 0, y: 0 };
let sending = null; // interval while input is non-zero
let lastSent = { linear: 0, angular: 0 };

const KEYMAP = {
  w: "fwd", arrowup: "fwd", s: "back", arrowdown: "back", a: "left", arrowleft: "left", d: "right", arrowright: "right",
};

function currentInput() {
  if (stick.active) return { linear: Math.max(-1, Math.min(1, stick.y)), angular: Math.max(-1, Math.min(1, -stick.x)) };
  const has = (k) => [...keys].some((key) => KEYMAP[key] === k);
  return { linear: (has("fwd") ? 1 : 0) - (has("back") ? 1 : 0), angular: (has("left") ? 1 : 0) - (has("right") ? 1 : 0) };
}

function inputFrame(input) {
  return {
    type: "input", linear: input.linear, angular: input.angular,
    max_linear: Number($("max-linear")?.value ?? config.max_linear),
    max_angular: Number($("max-angular")?.value ?? config.max_angular),
  };
}

function inputChanged() {
  if (!canDrive) return;
  if (!robotOnline) { if (sending) stopInput("release"); return; }
  const input = currentInput();
  const moving = input.linear !== 0 || input.angular !== 0;
  if (moving) {
    if (estop) { showError(`${estop} — driving is blocked until an operator releases it.`); return; }
    if (lock.holder && !lock.you) { showError(`${lock.holder} is driving.`); return; }
    if (input.linear !== lastSent.linear || input.angular !== lastSent.angular || !sending) send(inputFrame(input));
    lastSent = input;
    if (!sending) sending = setInterval(() => send(inputFrame(currentInput())), SEND_INTERVAL_MS);
  } else {
    stopInput("release");
  }
}

function stopInput(type) {
  clearInterval(sending);
  sending = null;
  lastSent = { linear: 0, angular: 0 };
  send({ type });
}

const typing = (el) => el && (el.isContentEditable || ["INPUT", "TEXTAREA", "SELECT"].includes(el.tagName)) && el.type !== "range";
document.addEventListener("keydown", (ev) => {
  const key = ev.key.toLowerCase();
  if (!(key in KEYMAP) || typing(ev.target) || ev.ctrlKey || ev.metaKey || ev.altKey) return;
  ev.preventDefault();
  if (keys.has(key)) return; // auto-repeat
  keys.add(key);
  inputChanged();
});
document.addEventListener("keyup", (ev) => {
  const key = ev.key.toLowerCase();
  if (!keys.delete(key)) return;
  ev.preventDefault();
  inputChanged();
});
// Key-ups never arrive once the window loses focus or the page is hidden: stop now.
window.addEventListener("blur", () => { if (keys.size || stick.active) { keys.clear(); stopInput("release"); } });
document.addEventListener("visibilitychange", () => {
  if (document.visibilityState === "hidden") { keys.clear(); stick.active = false; stopInput("hidden"); }
});
window.addEventListener("pagehide", () => stopInput("hidden"));

const zone = $("stick");
if (zone) {
  // dynamicPage: the stick measures where it is on every press and move (its first included), so
  // an alert above it, the camera loading or a scroll never turns "up" into reverse.
  const manager = createStick({
    zone, mode: "static", position: { left: "50%", top: "50%" }, size: 140, dynamicPage: true, restOpacity: 1,
    color: { front: "var(--stick-knob)", back: "transparent" },
  });
  manager.on("move", (evt) => {
    const v = evt.data?.vector;
    if (!v) return;
    Object.assign(stick, { active: true, x: v.x, y: v.y });
    inputChanged();
  });
  manager.on("end", () => { Object.assign(stick, { active: false, x: 0, y: 0 }); inputChanged(); });
}

for (const id of ["max-linear", "max-angular"]) {
  const input = $(id);
  if (!input) continue;
  const out = $(`${id}-out`);
  const show = () => { out.textContent = Number(input.value).toFixed(2); };
  input.addEventListener("input", () => { show(); if (sending) send(inputFrame(currentInput())); });
  show();
}

$("lock-acquire")?.addEventListener("click", () => send({ type: "acquire" }));
$("lock-release")?.addEventListener("click", () => { stopInput("release"); send({ type: "unlock" }); });
$("lock-takeover")?.addEventListener("click", () => {
  if (confirm(`Take the drive lock from ${lock.holder}? The robot stops first.`)) send({ type: "takeover" });
});
renderLock();
