// The live websocket shared by every page: reconnects with backoff, keeps the
// header's robot pill current, and hands topic updates to the page.

const pill = () => document.getElementById("link-pill");

export function notify(message, level = "info", { timeout = 6000 } = {}) {
  const box = document.getElementById("notices");
  if (!box) return;
  const el = document.createElement("div");
  el.className = `notice notice-${level}`;
  el.setAttribute("role", level === "error" ? "alert" : "status");
  el.textContent = message;
  const close = document.createElement("button");
  close.className = "linkish";
  close.type = "button";
  close.textContent = "×";
  close.setAttribute("aria-label", "Dismiss");
  close.onclick = () => el.remove();
  el.append(close);
  box.append(el);
  if (timeout) setTimeout(() => el.remove(), timeout);
}

export function csrfToken() {
  const m = document.cookie.match(/(?:^|; )csrftoken=([^;]+)/);
  return m ? decodeURIComponent(m[1]) : "";
}

// POST JSON to the API; resolves to the JSON body, rejects with an Error carrying the server's message.
export async function postJSON(url, body = {}) {
  const res = await fetch(url, {
    method: "POST",
    headers: { "Content-Type": "application/json", "X-CSRFToken": csrfToken() },
    credentials: "same-origin",
    body: JSON.stringify(body),
  });
  let data = {};
  try { data = await res.json(); } catch { /* empty body */ }
  if (!res.ok) {
    const err = new Error(data.detail || data.message || `Request failed (${res.status})`);
    err.status = res.status;
    err.data = data;
    throw err;
  }
  return data;
}

export function formatAge(seconds) {
  if (seconds == null || !isFinite(seconds)) return "never";
  if (seconds < 1.5) return "just now";
  if (seconds < 90) return `${Math.round(seconds)} s ago`;
  if (seconds < 5400) return `${Math.round(seconds / 60)} min ago`;
  return `${Math.round(seconds / 3600)} h ago`;
}

export function connectLive({ keys = [], onUpdate = () => {}, onStatus = () => {}, onMessage = () => {}, onOpen = () => {} } = {}) {
  let ws = null;
  let delay = 500;
  let closedByUs = false;
  let watching = new Set(keys);
  const queue = [];

  function send(obj) {
    if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(obj));
    else queue.push(obj);
  }

  function setPill(status) {
    const el = pill();
    if (!el) return;
    el.className = "pill " + (status.connected ? "pill-ok" : "pill-bad");
    el.textContent = status.connected ? "robot online" : (status.link_running === false ? "link down" : "robot offline");
    el.title = status.url || "";
  }

  function open() {
    const proto = location.protocol === "https:" ? "wss" : "ws";
    ws = new WebSocket(`${proto}://${location.host}/ws/live/`);
    ws.onopen = () => {
      delay = 500;
      document.body.classList.remove("socket-down");
      if (watching.size) ws.send(JSON.stringify({ action: "watch", keys: [...watching] }));
      while (queue.length) ws.send(JSON.stringify(queue.shift()));
      onOpen();
    };
    ws.onmessage = (ev) => {
      const frame = JSON.parse(ev.data);
      if (frame.kind === "update") onUpdate(frame);
      else if (frame.kind === "status") { setPill(frame); onStatus(frame); }
      else if (frame.kind === "error") notify(frame.message, "error");
      else if (frame.kind === "notice") notify(frame.message, "info");
      onMessage(frame);
    };
    ws.onclose = (ev) => {
      if (closedByUs) return;
      document.body.classList.add("socket-down");
      setPill({ connected: false, link_running: false, url: "server connection lost" });
      if (ev.code === 4401) { location.href = "/accounts/login/?next=" + encodeURIComponent(location.pathname); return; }
      onStatus({ connected: false, server_down: true });
      setTimeout(open, delay);
      delay = Math.min(delay * 2, 8000);
    };
  }
  open();
  return {
    send,
    watch(more) { more.forEach((k) => watching.add(k)); send({ action: "watch", keys: more }); },
    close() { closedByUs = true; ws && ws.close(); },
  };
}
