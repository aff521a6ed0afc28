// The dashboard's alert strip: notices that stay until dismissed, cleared or expired.
//
// Two kinds: a condition ("robot offline", "battery low") shows while it holds; an event
// (an ERROR line in the robot log) shows once per source with a repeat count, expires after
// ttl_s, and once dismissed or cleared stays away across page loads (the browser remembers
// up to when it was cleared, so the server's replay of recent log lines does not bring it back).
import { noticeElement, updateNotice } from "./notices.js";

export class AlertStrip {
  constructor(box, { ttlS = 600, maxEvents = 3, storageKey = "cyborg.alerts" } = {}) {
    this.box = box;
    this.ttlS = ttlS;
    this.maxEvents = maxEvents;
    this.storageKey = storageKey;
    this.memory = this.#load();
    this.events = new Map(); // id -> {text, level, at, repeats, el}
    this.conditions = new Map(); // id -> {el, dismissed}
    this.more = document.createElement("p");
    this.more.className = "alerts-more small muted";
    setInterval(() => this.#expire(), 5000);
  }

  #load() {
    try { return { clearedAt: 0, dismissed: {}, ...JSON.parse(localStorage.getItem(this.storageKey) || "{}") }; } catch { return { clearedAt: 0, dismissed: {} }; }
  }

  #save() {
    try { localStorage.setItem(this.storageKey, JSON.stringify(this.memory)); } catch { /* private mode: remember for this page only */ }
  }

  // Show text while on is true; its time is when it began. Dismissed, it stays away until on turns false.
  condition(id, on, text, level = "warn") {
    const known = this.conditions.get(id);
    if (!on) { known?.el.remove(); this.conditions.delete(id); return; }
    if (known) {
      if (!known.dismissed) updateNotice(known.el, { message: text, at: known.at });
      return;
    }
    const entry = { at: Date.now() / 1000, dismissed: false };
    entry.el = noticeElement({ message: text, level, at: entry.at, kind: "alert",
      onDismiss: () => { entry.dismissed = true; } });
    entry.el.dataset.alert = id;
    this.conditions.set(id, entry);
    this.box.prepend(entry.el);
  }

  // An event from source id at time at (seconds): the newest per source is shown, with a count.
  event(id, text, { level = "error", at = Date.now() / 1000 } = {}) {
    const now = Date.now() / 1000;
    if (at <= this.memory.clearedAt || at <= (this.memory.dismissed[id] ?? 0) || now - at > this.ttlS) return;
    const known = this.events.get(id);
    if (known && at < known.at) return;
    const entry = known ?? { repeats: 0 };
    Object.assign(entry, { text, level, at, repeats: entry.repeats + 1 });
    if (!entry.el) {
      entry.el = noticeElement({ message: text, level, at, kind: "alert", onDismiss: () => this.dismiss(id) });
      entry.el.dataset.alert = id;
    }
    entry.el.className = `alert alert-${level}`;
    updateNotice(entry.el, { message: text, at, repeats: entry.repeats });
    this.events.set(id, entry);
    this.#render();
  }

  dismiss(id) {
    const entry = this.events.get(id);
    if (!entry) return;
    this.memory.dismissed[id] = entry.at;
    this.events.delete(id);
    entry.el.remove();
    this.#save();
    this.#render();
  }

  // Remove every event alert, and keep those from before now away.
  clear() {
    this.memory = { clearedAt: Date.now() / 1000, dismissed: {} };
    this.#save();
    for (const entry of this.events.values()) entry.el.remove();
    this.events.clear();
    this.#render();
  }

  #expire() {
    const now = Date.now() / 1000;
    let changed = false;
    for (const [id, entry] of this.events) {
      if (now - entry.at > this.ttlS) { entry.el.remove(); this.events.delete(id); changed = true; }
    }
    if (changed) this.#render();
  }

  // Newest first, at most maxEvents, then how many more there are.
  #render() {
    const sorted = [...this.events.values()].sort((a, b) => b.at - a.at);
    sorted.forEach((entry, i) => {
      if (i < this.maxEvents) this.box.append(entry.el);
      else entry.el.remove();
    });
    const hidden = sorted.length - this.maxEvents;
    this.more.textContent = hidden > 0 ? `${hidden} more ${hidden === 1 ? "source reports" : "sources report"} errors: see the robot log.` : "";
    if (hidden > 0) this.box.append(this.more); else this.more.remove();
  }
}
