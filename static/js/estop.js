// The emergency stop button in every page's header (operators and admins).
import { notify, postJSON } from "./api.js";
import { site } from "./config.js";

const button = document.getElementById("estop-btn");
button?.addEventListener("click", async () => {
  button.disabled = true;
  try {
    const report = await postJSON(site.urls.estop);
    notify("Emergency stop: velocity zero, navigation cancelled, motors disabled, mode stop.", "warn", { timeout: 10000 });
    button.dataset.result = report.ok ? "ok" : "partial";
  } catch (err) {
    const steps = err.data?.steps?.map((s) => `${s.step}: ${s.ok ? "ok" : s.detail}`).join("; ");
    notify(steps ? `Emergency stop incomplete — ${steps}` : `Emergency stop failed: ${err.message}`, "error", { timeout: 0 });
    button.dataset.result = "failed";
  } finally {
    button.disabled = false;
  }
});
