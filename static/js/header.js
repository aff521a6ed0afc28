// The header on every page: the robot link pill follows the live socket's status.
import { live } from "./live.js";

const pill = document.getElementById("link-pill");

live.onStatus((status) => {
  if (!pill) return;
  pill.className = `pill ${status.connected ? "pill-ok" : "pill-bad"}`;
  pill.textContent = status.connected ? "robot online" : (status.link_running === false ? "link down" : "robot offline");
  pill.title = status.url || "";
});
