// The Alerts page: your choice of alerts beyond the tab, Web Push in this browser, and the history's times.
import { notify, request } from "./api.js";
import { readConfig } from "./config.js";
import { formatTime } from "./time.js";

const config = readConfig("alerts-config");
const form = document.getElementById("alert-choice");
const result = document.getElementById("alert-choice-result");

document.querySelectorAll("time[data-epoch]").forEach((el) => {
  const t = Number(el.dataset.epoch);
  el.dateTime = new Date(t * 1000).toISOString();
  el.textContent = formatTime(t, { label: true });
});

let publicKey = "";

function show(choice) {
  publicKey = choice.push_public_key;
  form.querySelectorAll('input[name="kinds"]').forEach((box) => { box.checked = choice.kinds.includes(box.value); });
  form.elements.min_severity.value = choice.min_severity;
  form.elements.by_email.checked = choice.by_email;
  form.elements.by_push.checked = choice.by_push;
  form.querySelector('[data-field="email"]').textContent = choice.email ? `(${choice.email})` : "(your account has no e-mail address)";
  form.querySelector('[data-field="browsers"]').textContent = `(${choice.push_browsers} browser${choice.push_browsers === 1 ? "" : "s"})`;
}

form.addEventListener("submit", async (ev) => {
  ev.preventDefault();
  try {
    show(await request("PATCH", config.choice_url, {
      kinds: [...form.querySelectorAll('input[name="kinds"]:checked')].map((b) => b.value),
      min_severity: form.elements.min_severity.value,
      by_email: form.elements.by_email.checked,
      by_push: form.elements.by_push.checked,
    }));
    result.textContent = "Saved.";
  } catch (e) {
    result.textContent = e.message;
  }
});

function keyBytes(b64) {
  const raw = atob(b64.replace(/-/g, "+").replace(/_/g, "/"));
  return Uint8Array.from(raw, (c) => c.charCodeAt(0));
}

// The worker's scope is its folder, not this page, so navigator.serviceWorker.ready would never
// resolve here: wait for this registration's own worker instead (push needs an active one).
function activated(registration) {
  const worker = registration.installing || registration.waiting || registration.active;
  if (worker.state === "activated") return Promise.resolve(registration);
  return new Promise((resolve) => {
    worker.addEventListener("statechange", () => { if (worker.state === "activated") resolve(registration); });
  });
}

document.getElementById("push-enable").addEventListener("click", async () => {
  if (!("serviceWorker" in navigator) || !("PushManager" in window)) {
    notify("This browser has no Web Push (it needs HTTPS, or localhost).", "error");
    return;
  }
  try {
    if (await Notification.requestPermission() !== "granted") throw new Error("Notifications are not allowed for this site.");
    const registration = await navigator.serviceWorker.register(config.worker_url);
    await activated(registration);
    const subscription = await registration.pushManager.subscribe({ userVisibleOnly: true, applicationServerKey: keyBytes(publicKey) });
    await request("POST", config.push_url, subscription.toJSON());
    show(await request("GET", config.choice_url));
    result.textContent = "This browser gets notifications now.";
  } catch (e) {
    result.textContent = `Could not turn notifications on: ${e.message}`;
  }
});

show(await request("GET", config.choice_url));
