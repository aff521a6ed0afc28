// The server-rendered configuration: the site's (base.html, "site-config") and each page's
// (json_script). Pages take every URL from here, never from a literal in the script.

export function readConfig(id) {
  const el = document.getElementById(id);
  return el ? JSON.parse(el.textContent) : null;
}

export const site = readConfig("site-config") ?? { urls: {}, commands: {} };

// A websocket URL on this page's host for a server path from the configuration.
export function socketURL(path) {
  const proto = location.protocol === "https:" ? "wss" : "ws";
  return `${proto}://${location.host}${path}`;
}

// A logout's own answer (which may first end the provider's session) must win over the sockets
// that this logout closes.
let loggingOut = false;
document.addEventListener("submit", (ev) => { if (ev.target.matches("form[data-logout]")) loggingOut = true; });

// Where a page sends the browser when the server says the session has ended.
export function toLogin() {
  if (loggingOut) return;
  location.href = `${site.urls.login}?next=${encodeURIComponent(location.pathname + location.search)}`;
}
