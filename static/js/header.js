// The header on every page: the robot link pill follows the live socket's status; on a
// phone the pages and the account sit behind the menu button.
import { initAlertStrip } from "./alert-strip.js";
import { linkState } from "./linkstate.js";
import { live } from "./live.js";
import "./shortcuts.js";
import "./theme.js";

const header = document.querySelector(".topbar");
const pill = document.getElementById("link-pill");
const menuButton = document.getElementById("menu-btn");

function setMenu(open) {
  header.dataset.menu = open ? "open" : "closed";
  menuButton?.setAttribute("aria-expanded", String(open));
}
menuButton?.addEventListener("click", () => setMenu(header.dataset.menu !== "open"));
document.addEventListener("click", (ev) => { if (!header.contains(ev.target)) setMenu(false); });

const strip = document.getElementById("services-strip");

// What this web server cannot reach (its own checks, beside the link's status): on every page.
function showServices(down) {
  if (!strip) return;
  const lines = Object.values(down ?? {});
  strip.hidden = lines.length === 0;
  strip.textContent = lines.length ? `${lines.join(". ")}. The E-STOP still works.` : "";
}

live.onStatus((status) => {
  showServices(status.services_down);
  if (!pill) return;
  const state = linkState(status);
  pill.className = `pill ${state.ok ? "pill-ok" : "pill-bad"}`;
  pill.textContent = state.label;
  pill.dataset.state = state.label;
  pill.title = state.why || status.url || "";
});

initAlertStrip(document.getElementById("alert-strip"), document.getElementById("header-battery"));
