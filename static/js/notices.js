// The one notice component: a timed, dismissable line with a level. Toasts (notify) sit in
// a bar under the header, in the page's flow, so they never cover a control or the E-STOP.
// The same message again bumps a counter instead of piling up.
import { formatTime } from "./time.js";

const MAX_TOASTS = 4;
const DEFAULT_TIMEOUT_MS = { error: 10000, warn: 8000, ok: 4000, info: 5000 };

// A notice element: <time> · message · ×; onDismiss runs when its × is pressed. kind is
// "notice" (a toast) or "alert" (the dashboard's strip): same parts, its own classes.
export function noticeElement({ message, level = "info", at = Date.now() / 1000, onDismiss = null, kind = "notice" }) {
  const el = document.createElement("div");
  el.className = `${kind} ${kind}-${level}`;
  el.setAttribute("role", level === "error" ? "alert" : "status");
  const when = document.createElement("time");
  when.className = "notice-time";
  const text = document.createElement("span");
  text.className = "notice-text";
  const count = document.createElement("span");
  count.className = "notice-count";
  const close = document.createElement("button");
  close.className = "notice-close";
  close.type = "button";
  close.textContent = "×";
  close.setAttribute("aria-label", "Dismiss");
  close.onclick = () => { el.remove(); onDismiss?.(); };
  el.append(when, text, count, close);
  updateNotice(el, { message, at });
  return el;
}

export function updateNotice(el, { message, at, repeats = 0 }) {
  const when = el.querySelector(".notice-time");
  when.dateTime = new Date(at * 1000).toISOString();
  when.textContent = formatTime(at, { date: Date.now() / 1000 - at > 43200, label: true });
  el.querySelector(".notice-text").textContent = message;
  el.querySelector(".notice-count").textContent = repeats > 1 ? `×${repeats}` : "";
}

const timers = new WeakMap();

// Show a toast; timeout 0 keeps it until dismissed. The same key (default: level + message)
// replaces the earlier toast and counts the repeats.
export function notify(message, level = "info", { timeout = DEFAULT_TIMEOUT_MS[level] ?? 5000, key = null } = {}) {
  const box = document.getElementById("notices");
  if (!box) return null;
  const id = key ?? `${level}:${message}`;
  const now = Date.now() / 1000;
  let el = [...box.children].find((c) => c.dataset.key === id);
  if (el) {
    const repeats = Number(el.dataset.repeats || 1) + 1;
    el.dataset.repeats = String(repeats);
    el.className = `notice notice-${level}`;
    updateNotice(el, { message, at: now, repeats });
    box.append(el); // newest last
  } else {
    el = noticeElement({ message, level, at: now });
    el.dataset.key = id;
    box.append(el);
    while (box.childElementCount > MAX_TOASTS) box.firstElementChild.remove();
  }
  clearTimeout(timers.get(el));
  if (timeout) timers.set(el, setTimeout(() => el.remove(), timeout));
  return el;
}

// Remove the toasts whose key starts with prefix (a condition that no longer holds).
export function withdraw(prefix) {
  document.querySelectorAll("#notices > .notice").forEach((el) => {
    if (el.dataset.key?.startsWith(prefix)) el.remove();
  });
}
