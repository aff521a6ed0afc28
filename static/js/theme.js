// The colour theme: "system" follows the browser's prefers-color-scheme (static/css/theme.css);
// a person's own choice (kept on the server, /api/me/theme/) overrides it on every page at once.
import { notify, request } from "./api.js";
import { site } from "./config.js";

const select = document.getElementById("theme-select");
select?.addEventListener("change", async () => {
  const previous = document.documentElement.dataset.theme;
  document.documentElement.dataset.theme = select.value;
  try {
    await request("PATCH", site.urls.theme, { theme: select.value });
  } catch (err) {
    document.documentElement.dataset.theme = previous;
    select.value = previous;
    notify(`Theme not saved: ${err.message}`, "error");
  }
});
