// The header on every page: the robot link pill follows the live socket's status; on a
// phone the pages and the account sit behind the menu button.
import { live } from "./live.js";

const header = document.querySelector(".topbar");
const pill = document.getElementById("link-pill");
const menuButton = document.getElementById("menu-btn");

function setMenu(open) {
  header.dataset.menu = open ? "open" : "closed";
  menuButton?.setAttribute("aria-expanded", String(open));
}
menuButton?.addEventListener("click", () => setMenu(header.dataset.menu !== "open"));
document.addEventListener("click", (ev) => { if (!header.contains(ev.target)) setMenu(false); });

live.onStatus((status) => {
  if (!pill) return;
  pill.className = `pill ${status.connected ? "pill-ok" : "pill-bad"}`;
  pill.textContent = status.connected ? "robot online" : (status.link_running === false ? "link down" : "robot offline");
  pill.title = status.url || "";
});
