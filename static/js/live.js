// The live websocket, one per page: pages import `live` and subscribe to the topic keys they
// show. It reconnects with backoff, re-watches everything after a reconnect (but a topic the
// server refused), hands a late subscriber the latest frame of a key already watched, and
// reports the link status.
//
//   import { live } from "./live.js";
//   const stop = live.watch(["battery_soc"], (frame) => …);   // frame = {key, msg, t}
//   stop();                                      // keys no handler wants are unwatched
//   live.onStatus((status) => …);                // {connected, link_running, since, url, …} or {server_down}
//   live.onOpen(() => …);                        // after every (re)connect
//   live.send({action: "reconnect"});
//   const close = live.watchTopic("/rosout", (frame) => …, {onRefused: (error) => …});   // any topic, by name
import { site, socketURL, toLogin } from "./config.js";
import { notify } from "./notices.js";

const UNAUTHENTICATED = 4401;

class Live {
  #ws = null;
  #delay = 500;
  #started = false;
  #queue = [];
  #handlers = new Map(); // key -> Set(handler)
  #latest = new Map(); // key -> last frame
  #statusHandlers = new Set();
  #openHandlers = new Set();
  #topics = new Map(); // topic name -> Set(handler) (the topics page: frames under "topic:<name>")
  #refusals = new Map(); // topic name -> Set(onRefused)
  #refused = new Map(); // topic name -> the server's refusal: not asked for again while it is watched
  status = null;

  // Any topic of the robot's by name (summarised by the server); returns a function that closes it.
  // onRefused(error) runs when the server refuses it (no such topic, a bad name); a refused topic
  // is not asked for again after a reconnect. A robot offline is no refusal: the watch stands.
  watchTopic(name, handler, { onRefused = null } = {}) {
    const key = `topic:${name}`;
    if (!this.#topics.has(name)) {
      this.#topics.set(name, new Set());
      this.#refusals.set(name, new Set());
      this.send({ action: "watch_topic", topic: name });
    }
    this.#topics.get(name).add(handler);
    if (onRefused) this.#refusals.get(name).add(onRefused);
    const refusal = this.#refused.get(name);
    if (refusal && onRefused) queueMicrotask(() => onRefused(refusal));
    if (!this.#handlers.has(key)) this.#handlers.set(key, new Set());
    this.#handlers.get(key).add(handler);
    const last = this.#latest.get(key);
    if (last) queueMicrotask(() => handler(last));
    this.start();
    return () => {
      const set = this.#topics.get(name);
      set?.delete(handler);
      this.#handlers.get(key)?.delete(handler);
      if (onRefused) this.#refusals.get(name)?.delete(onRefused);
      if (set && !set.size) {
        this.#topics.delete(name);
        this.#refusals.delete(name);
        this.#refused.delete(name);
        this.#handlers.delete(key);
        this.#latest.delete(key);
        this.send({ action: "unwatch_topic", topic: name });
      }
    };
  }

  // Subscribe handler to frames of keys; returns a function that unsubscribes.
  watch(keys, handler) {
    const fresh = keys.filter((k) => !this.#handlers.has(k));
    for (const key of keys) {
      if (!this.#handlers.has(key)) this.#handlers.set(key, new Set());
      this.#handlers.get(key).add(handler);
      const last = this.#latest.get(key);
      if (last) queueMicrotask(() => handler(last));
    }
    if (fresh.length) this.send({ action: "watch", keys: fresh });
    this.start();
    return () => this.#unwatch(keys, handler);
  }

  // A key nobody on the page listens to any more is no longer sent by the server.
  #unwatch(keys, handler) {
    const gone = [];
    for (const key of keys) {
      const set = this.#handlers.get(key);
      if (!set) continue;
      set.delete(handler);
      if (!set.size) { this.#handlers.delete(key); this.#latest.delete(key); gone.push(key); }
    }
    if (gone.length) this.send({ action: "unwatch", keys: gone });
  }

  onStatus(handler) {
    this.#statusHandlers.add(handler);
    if (this.status) queueMicrotask(() => handler(this.status));
    this.start();
  }

  onOpen(handler) { this.#openHandlers.add(handler); this.start(); }

  send(obj) {
    if (this.#ws?.readyState === WebSocket.OPEN) this.#ws.send(JSON.stringify(obj));
    // watches are re-sent on open anyway, and a fresh socket watches nothing to unwatch
    else if (!["watch", "unwatch", "watch_topic", "unwatch_topic"].includes(obj.action)) this.#queue.push(obj);
  }

  start() {
    if (this.#started) return;
    this.#started = true;
    this.#open();
  }

  #refuse(error) {
    this.#refused.set(error.topic, error);
    for (const fn of this.#refusals.get(error.topic) ?? []) {
      try { fn(error); } catch (e) { console.error("topic refused", error.topic, e); }
    }
  }

  #setStatus(status) {
    this.status = status;
    for (const fn of this.#statusHandlers) fn(status);
  }

  #open() {
    const ws = new WebSocket(socketURL(site.urls.live_socket));
    this.#ws = ws;
    ws.onopen = () => {
      this.#delay = 500;
      document.body.classList.remove("socket-down");
      const keys = [...this.#handlers.keys()].filter((k) => !k.startsWith("topic:"));
      if (keys.length) ws.send(JSON.stringify({ action: "watch", keys }));
      for (const name of this.#topics.keys()) {
        if (!this.#refused.has(name)) ws.send(JSON.stringify({ action: "watch_topic", topic: name }));
      }
      while (this.#queue.length) ws.send(JSON.stringify(this.#queue.shift()));
      for (const fn of this.#openHandlers) fn();
    };
    ws.onmessage = (ev) => {
      const frame = JSON.parse(ev.data);
      // One frame per server tick carries every key that changed.
      const updates = frame.kind === "updates" ? frame.updates : frame.kind === "update" ? [frame] : null;
      if (updates) {
        for (const update of updates) {
          const one = { kind: "update", ...update };
          this.#latest.set(one.key, one);
          for (const fn of this.#handlers.get(one.key) ?? []) {
            try { fn(one); } catch (e) { console.error("live update", one.key, e); }
          }
        }
      } else if (frame.kind === "status") this.#setStatus(frame);
      else if (frame.kind === "error") {
        if (frame.topic && frame.code !== "offline" && this.#topics.has(frame.topic)) this.#refuse(frame);
        notify(frame.message, "error");
      }
      else if (frame.kind === "notice") notify(frame.message, "info");
    };
    ws.onclose = (ev) => {
      document.body.classList.add("socket-down");
      if (ev.code === UNAUTHENTICATED) { toLogin(); return; }
      this.#setStatus({ connected: false, server_down: true, link_running: false, url: "server connection lost" });
      setTimeout(() => this.#open(), this.#delay);
      this.#delay = Math.min(this.#delay * 2, 8000);
    };
  }
}

export const live = new Live();
