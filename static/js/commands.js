// Command controls: mode commander, events, speech, emotion, sound, dome, motors.
// Every control posts to the REST API (session + CSRF) and shows the outcome.
//
// initCommands(root) wires every [data-command] button and form under root; the values
// it shows come from the page's live socket.
import { notify, postJSON } from "./api.js";
import { site } from "./config.js";
import { live } from "./live.js";
import { formatTime } from "./time.js";

const KEYS = ["state_change", "smach_status", "state_transitions", "mode_request"];

// Send one command; resolves to the API's answer, or null after telling the user what failed.
export async function sendCommand(command, body, { control = null, result = null } = {}) {
  if (control) control.disabled = true;
  try {
    const url = site.commands[command];
    if (!url) throw new Error(`Unknown command ${command}`);
    const answer = await postJSON(url, body);
    notify(answer.outcome, "ok");
    showResult(result, answer.outcome, true);
    return answer;
  } catch (err) {
    notify(err.message, "error");
    showResult(result, err.message, false);
    return null;
  } finally {
    if (control) control.disabled = false;
  }
}

// The card's result line: what the robot was told, when, and whether it worked.
function showResult(el, text, ok) {
  if (!el) return;
  el.textContent = `${ok ? "✓" : "✗"} ${text} · ${formatTime(Date.now() / 1000, { date: false, label: true })}`;
  el.classList.toggle("result-ok", ok);
  el.classList.toggle("result-bad", !ok);
}

function formBody(form) {
  const body = {};
  for (const [name, value] of new FormData(form)) body[name] = typeof value === "string" ? value.trim() : value;
  return body;
}

// Behaviour is a container: any state other than the top-level ones counts as "in behaviour".
function reached(config, mode, state) {
  const target = config.targets[mode];
  if (!state) return false;
  if (target === "behaviour") return !config.outside_behaviour.includes(state);
  return state === target;
}

export function initCommands(root = document) {
  const field = (name) => root.querySelectorAll(`[data-field="${name}"]`);
  const set = (name, text) => field(name).forEach((el) => { el.textContent = text; });
  const configEl = root.querySelector("[data-commands='mode'][data-config]");
  const config = configEl ? JSON.parse(configEl.dataset.config) : null;
  const seen = { request: null, requestAt: 0, change: null, top: null, since: null };

  function resultFor(el) {
    const name = el.dataset.resultTarget || el.dataset.command;
    const card = el.closest(".card, [data-commands]");
    return card?.querySelector(`[data-result="${name}"]`) || card?.querySelector('[data-result="*"]') || null;
  }

  root.addEventListener("click", (ev) => {
    const button = ev.target.closest("button[data-command]");
    if (!button || !root.contains(button) || button.disabled) return;
    sendCommand(button.dataset.command, JSON.parse(button.dataset.body || "{}"),
      { control: button, result: resultFor(button) });
  });
  root.addEventListener("submit", async (ev) => {
    const form = ev.target.closest("form[data-command]");
    if (!form) return;
    ev.preventDefault();
    const submit = form.querySelector("[type=submit]");
    const answer = await sendCommand(form.dataset.command, formBody(form), { control: submit, result: resultFor(form) });
    if (answer && form.dataset.command !== "playback") form.querySelectorAll("textarea, input").forEach((el) => { el.value = ""; });
    form.querySelectorAll("[data-counter]").forEach(updateCounter);
  });
  root.addEventListener("input", (ev) => {
    ev.target.closest("form")?.querySelectorAll("[data-counter]").forEach(updateCounter);
  });

  function updateCounter(counter) {
    const text = counter.closest("form").querySelector("textarea");
    const max = Number(counter.dataset.max);
    counter.textContent = `${text.value.length} / ${max}`;
    counter.classList.toggle("result-bad", text.value.length > max);
  }

  function renderEvents(msg) {
    let events = {};
    try { events = JSON.parse(msg.data || "{}"); } catch { /* not JSON: show none */ }
    root.querySelectorAll("[data-events]").forEach((box) => {
      const disabled = box.hasAttribute("data-disabled");
      const buttons = Object.entries(events).map(([event, next]) => {
        const b = document.createElement("button");
        b.type = "button";
        b.className = "btn event-btn";
        b.dataset.command = "event";
        b.dataset.body = JSON.stringify({ event });
        b.disabled = disabled;
        b.textContent = `${event} → ${next}`;
        return b;
      });
      if (buttons.length) box.replaceChildren(...buttons);
      else box.textContent = "No events available from this state.";
    });
  }

  // A request that failed before the robot (re)connected says nothing about it now.
  function currentRequest() {
    const r = seen.request;
    if (r?.status === "failed" && seen.since && seen.requestAt < seen.since) return null;
    return r;
  }

  // Where the state machine is: the newer of its last transition and its introspection's top-level
  // active state, and neither from before the robot (re)connected (a restarted robot is in startup,
  // whatever it said before).
  function currentState() {
    const fresh = [seen.change, seen.top].filter((s) => s && (!seen.since || s.t >= seen.since));
    fresh.sort((a, b) => b.t - a.t);
    return fresh[0]?.state ?? null;
  }

  function renderMode() {
    if (!config) return;
    const r = currentRequest();
    const state = currentState();
    root.querySelectorAll("[data-mode]").forEach((b) => {
      const on = r?.mode === b.dataset.mode;
      b.classList.toggle("active", on);
      b.setAttribute("aria-pressed", String(on));
    });
    if (!r) {
      set("mode.request", "—");
      set("mode.reached", state ?? "—");
      field("mode.mismatch").forEach((el) => { el.hidden = true; });
      return;
    }
    const status = { running: "applying…", sent: "sent", failed: `failed: ${r.error}` }[r.status] || r.status;
    set("mode.request", `${r.mode}${r.by ? ` by ${r.by}` : ""} · ${status}`);
    const ok = reached(config, r.mode, state);
    set("mode.reached", state ? `${state}${ok ? " ✓" : ""}` : "—");
    const late = Date.now() / 1000 - seen.requestAt > config.grace_s;
    const mismatch = r.status !== "running" && state != null && !ok && late;
    field("mode.mismatch").forEach((el) => {
      el.hidden = !mismatch;
      el.textContent = mismatch
        ? `Requested ${r.mode} (state ${config.targets[r.mode]}), but the state machine is in ${state}.`
        : "";
    });
  }

  function onUpdate(frame) {
    if (frame.key === "state_change") seen.change = { state: frame.msg.to_system_state, t: frame.t };
    else if (frame.key === "smach_status") {
      // The top container (one level deep, /SM_ROOT) names the top-level state.
      if ((frame.msg.path.match(/\//g) || []).length !== 1) return;
      const active = frame.msg.active_states?.[0];
      seen.top = active ? { state: active, t: frame.t } : null;
    }
    else if (frame.key === "state_transitions") renderEvents(frame.msg);
    else if (frame.key === "mode_request") {
      seen.request = frame.msg;
      seen.requestAt = Math.min(Date.now() / 1000, frame.t);
    } else return;
    renderMode();
  }

  live.watch(KEYS, onUpdate);
  live.onStatus((status) => { seen.since = status.connected ? status.since : null; renderMode(); });
  setInterval(renderMode, 1000);
  return { send: sendCommand };
}
