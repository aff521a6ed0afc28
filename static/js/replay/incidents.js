// The incidents page: mark this moment (operators), release an incident to retention (admins), times in the site's zone.
import { notify, request } from "../api.js";
import { formatTime } from "../time.js";

const urls = JSON.parse(document.getElementById("incidents-urls").textContent);

for (const el of document.querySelectorAll("time[data-epoch]")) {
  el.textContent = formatTime(Number(el.dataset.epoch), { label: true });
}

const form = document.getElementById("mark-form");
if (form) {
  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    const note = document.getElementById("mark-note").value.trim();
    try {
      await request("POST", urls.incidents, { note: note || "marked moment" });
      window.location.reload();
    } catch (error) { notify(error.message, "error"); }
  });
}

for (const button of document.querySelectorAll("[data-release]")) {
  button.addEventListener("click", async () => {
    try {
      await request("POST", `${urls.incidents}${button.dataset.release}/release/`);
      window.location.reload();
    } catch (error) { notify(error.message, "error"); }
  });
}
