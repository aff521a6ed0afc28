// The alert strip and the battery in every page's header, live over the page's one socket.
//
// The server raises alerts (robot.alerts): each arrives with when it began, so a reload shows the
// same time; its severity, how often it repeated, and who acknowledged it. Operators acknowledge
// here; an acknowledged event goes, an acknowledged condition stays (dimmed) until it clears.
import { notify, request } from "./api.js";
import { live } from "./live.js";
import { formatTime, zoneLabel } from "./time.js";

const SHOWN = 3;

function since(t) {
  const old = Date.now() / 1000 - t > 43200;
  return formatTime(t, { date: old, label: true });
}

function alertElement(alert, { ackUrl }) {
  const el = document.createElement("div");
  el.className = `strip-alert strip-${alert.severity}${alert.acked_at ? " strip-acked" : ""}`;
  el.dataset.alertKey = alert.key;
  el.dataset.alertId = alert.id;
  el.dataset.kind = alert.kind;
  el.setAttribute("role", alert.acked_at ? "status" : "alert");
  const when = document.createElement("time");
  when.className = "strip-time";
  when.dateTime = new Date(alert.started_at * 1000).toISOString();
  when.textContent = since(alert.started_at);
  when.title = `began ${formatTime(alert.started_at, { label: true })}`;
  const text = document.createElement("span");
  text.className = "strip-text";
  text.textContent = alert.text;
  el.append(when, text);
  if (alert.count > 1) {
    const count = document.createElement("span");
    count.className = "strip-count";
    count.textContent = `×${alert.count}`;
    el.append(count);
  }
  if (alert.acked_at) {
    const who = document.createElement("span");
    who.className = "strip-acked-by";
    who.textContent = `acknowledged by ${alert.acked_by} at ${formatTime(alert.acked_at, { date: false })}`;
    el.append(who);
  } else if (ackUrl) {
    const ack = document.createElement("button");
    ack.type = "button";
    ack.className = "strip-ack";
    ack.textContent = "Acknowledge";
    ack.addEventListener("click", async () => {
      ack.disabled = true;
      try {
        await request("POST", ackUrl.replace("ALERT_ID", alert.id));
      } catch (e) {
        ack.disabled = false;
        notify(e.message, "error");
      }
    });
    el.append(ack);
  }
  return el;
}

export function initAlertStrip(strip, battery) {
  if (!strip) return;
  const ackUrl = strip.dataset.ackUrl || "";
  let expanded = false;
  let latest = [];

  // Unacknowledged first, then the most severe, then the newest.
  const RANK = { critical: 3, error: 2, warning: 1 };
  const order = (a, b) => (!!a.acked_at - !!b.acked_at) || (RANK[b.severity] ?? 0) - (RANK[a.severity] ?? 0)
    || b.started_at - a.started_at;

  function render() {
    const alerts = [...latest].sort(order);
    const shown = expanded ? alerts : alerts.slice(0, SHOWN);
    const children = shown.map((a) => alertElement(a, { ackUrl }));
    if (alerts.length > SHOWN) {
      const more = document.createElement("button");
      more.type = "button";
      more.className = "strip-more linkish";
      more.textContent = expanded ? "Show fewer" : `${alerts.length - SHOWN} more alert${alerts.length - SHOWN === 1 ? "" : "s"}`;
      more.addEventListener("click", () => { expanded = !expanded; render(); });
      children.push(more);
    }
    strip.replaceChildren(...children);
    strip.hidden = alerts.length === 0;
    strip.dataset.count = String(alerts.length);
    battery?.classList.toggle("pill-bad", alerts.some((a) => a.kind === "battery_low"));
  }

  live.watch(["alerts"], (frame) => {
    latest = frame.msg.alerts ?? [];
    render();
  });
  if (battery) {
    live.watch(["battery_soc"], (frame) => {
      const pct = Math.round(Number(frame.msg.data) * 100);
      const word = document.createElement("span");
      word.className = "battery-word";
      word.textContent = "Battery ";
      battery.replaceChildren(word, `${pct} %`);
      battery.setAttribute("aria-label", `Battery ${pct} %`);
      battery.dataset.percent = String(pct);
      battery.title = `Battery ${pct} % at ${formatTime(frame.t, { date: false })} ${zoneLabel()}`;
    });
  }
}
