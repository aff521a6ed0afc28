// The header on every page: the robot link pill follows the live socket's status; on a
// phone the pages and the account sit behind the menu button.
import { initAlertStrip } from "./alert-strip.js";
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
  pill.className = `pill ${status.connected ? "pill-ok" : "pill-bad"}`;
  // "Command path down": the link runs but does not answer requests; nothing would reach the robot.
  // "Not responding": connected, but the robot has said nothing for a while (hung, frozen).
  const hung = status.robot_connected && status.responding === false;
  pill.textContent = status.connected ? "robot online" : status.link_running === false ? "link down"
    : status.command_path === false ? "command path down" : hung ? "not responding" : "robot offline";
  pill.dataset.state = pill.textContent;
  pill.title = status.command_path === false
    ? "The robot link does not answer requests: commands, including E-STOP, cannot reach the robot"
    : hung ? "Connected, but the robot has not answered for a while: commands are refused until it does"
    : status.url || "";
});

initAlertStrip(document.getElementById("alert-strip"), document.getElementById("header-battery"));
