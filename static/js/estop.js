// The E-STOP on every page: the button (operators), the Esc shortcut, and the banner every
// user sees while the stop is latched (who, when, which step failed), with the release.
import { notify, postJSON } from "./api.js";
import { site } from "./config.js";
import { live } from "./live.js";

const button = document.getElementById("estop-btn");
const banner = document.getElementById("estop-banner");
const release = document.getElementById("estop-release");
const SHORTCUT = "Escape";
let shown = null; // the latch on the banner
let robotOnline = false;

function render(latch) {
  if (!banner || !latch) return;
  shown = latch;
  banner.hidden = !latch.latched;
  banner.dataset.latched = String(!!latch.latched);
  banner.dataset.by = latch.by || "";
  document.getElementById("estop-banner-text").textContent = latch.latched ? latch.message : "";
  document.getElementById("estop-banner-failed").textContent = latch.latched ? failedText(latch.steps || []) : "";
}

// A step refused because the robot was away is stale once it is back: say so, not "Failed" (the latch holds).
const AWAY = /^Robot (offline|not responding)/;
function failedText(steps) {
  const failed = steps.filter((s) => !s.ok);
  const stale = robotOnline ? failed.filter((s) => AWAY.test(s.detail || "")) : [];
  const current = failed.filter((s) => !stale.includes(s));
  const parts = [];
  if (current.length) parts.push(`Failed: ${current.map((s) => `${s.step} (${s.detail})`).join("; ")}`);
  if (stale.length) {
    parts.push(`The robot is back; these steps did not reach it while it was away: ${stale.map((s) => s.step).join(", ")}. `
      + (button ? "Press E-STOP again to repeat them." : "An operator can repeat them with the E-STOP."));
  }
  return parts.join(" ");
}

async function engage() {
  if (!button) { notify("Only operators and admins can press the E-STOP.", "error"); return; }
  button.setAttribute("aria-busy", "true");
  try {
    const report = await postJSON(site.urls.estop);
    render(report.latch);
    button.dataset.result = "ok";
  } catch (err) {
    // A failing step still latches: the banner shows which one.
    if (err.data?.latch) render(err.data.latch);
    const steps = err.data?.steps?.filter((s) => !s.ok).map((s) => `${s.step}: ${s.detail}`).join("; ");
    notify(steps ? `E-STOP latched, but not every step succeeded — ${steps}` : `E-STOP failed: ${err.message}`, "error",
      { timeout: 0 });
    button.dataset.result = err.data?.latch?.latched ? "partial" : "failed";
  } finally {
    button.removeAttribute("aria-busy");
  }
}

// Never disabled while a press is under way: pressing again is always allowed.
button?.addEventListener("click", engage);
// Esc with a dialog open (the shortcut help, any other) closes that dialog and nothing else.
document.addEventListener("keydown", (ev) => {
  if (ev.key !== SHORTCUT || ev.repeat) return;
  ev.preventDefault();
  const dialog = [...document.querySelectorAll("dialog[open]")].pop();
  if (dialog) dialog.close();
  else engage();
}, { capture: true });

release?.addEventListener("click", async () => {
  if (!confirm("Release the E-STOP? Driving, goals and mode changes are allowed again (the motors stay off).")) return;
  try {
    render(await postJSON(site.urls.estop_release, { confirm: true }));
    notify("E-STOP released.", "ok");
  } catch (err) {
    notify(`E-STOP not released: ${err.message}`, "error");
  }
});

live.watch(["estop"], (frame) => render(frame.msg));
live.onStatus((status) => {
  if (status.connected === robotOnline) return;
  robotOnline = !!status.connected;
  render(shown);
});
