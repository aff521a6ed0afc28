// The state machine page: the robot's SMACH containers laid out by Graphviz (vendored
// @viz-js/viz, WebAssembly, loaded here only), the active states highlighted live, and the
// current state's outgoing transitions clickable for operators: a click sends that event
// through the command API (audited, role-checked, refused while E-STOPped).
//
// The server sends the graph (smach_graph: DOT text plus node and edge tables keyed by SMACH
// path) when the structure changes, and the active states (smach_active) when they move.
import { sendCommand } from "./commands.js";
import { readConfig } from "./config.js";
import { live } from "./live.js";
import { formatElapsed } from "./time.js";

const config = readConfig("smach-config");
const box = document.getElementById("smach-graph");
const canCommand = box.dataset.canCommand === "true";
const resultLine = document.getElementById("smach-result");
const eventsBox = document.getElementById("smach-events");
const set = (name, text) => document.querySelectorAll(`[data-field="${name}"]`).forEach((el) => { el.textContent = text; });
const latest = {}; // key -> frame

let vizReady = null;
let drawn = null; // {version, nodes: Map(path -> g), clusters: Map(path -> g), edges: [{from, event, to, el}]}
let drawing = null; // the graph message being laid out

const nameOf = (path) => path.split(/[/:]/).pop();

function viz() {
  vizReady ??= import(config.viz_url).then((module) => module.instance());
  return vizReady;
}

async function drawGraph(msg) {
  drawing = msg;
  let svg;
  try {
    svg = (await viz()).renderSVGElement(msg.dot);
  } catch (err) {
    set("smach.waiting", `Could not lay out the state machine: ${err.message ?? err}`);
    return;
  }
  if (drawing !== msg) return; // a newer structure arrived while this one was laid out
  svg.setAttribute("role", "img");
  svg.setAttribute("aria-label", `State machine with ${msg.nodes.length} states and outcomes`);
  const find = (id) => svg.querySelector(`#${CSS.escape(id)}`);
  const nodes = new Map(), clusters = new Map(), edges = [];
  for (const n of msg.nodes) {
    const el = find(n.id);
    if (!el) continue;
    el.dataset.path = n.path;
    el.dataset.kind = n.kind;
    nodes.set(n.path, el);
  }
  for (const [id, path] of Object.entries(msg.clusters)) {
    const el = find(id);
    if (el) { el.dataset.path = path; clusters.set(path, el); }
  }
  for (const e of msg.edges) {
    const el = find(e.id);
    if (!el) continue;
    Object.assign(el.dataset, { from: e.from, event: e.event, to: e.to });
    const line = el.querySelector("path");
    if (line) { // a wide transparent twin of the line: easier to hit with a finger
      const hit = line.cloneNode();
      hit.setAttribute("class", "hit");
      el.prepend(hit);
    }
    edges.push({ ...e, el });
  }
  box.replaceChildren(svg);
  for (const e of edges) padLabel(e.el);
  drawn = { version: msg.version, nodes, clusters, edges };
  renderActive();
}

// A label's target reaches a little beyond its letters (a finger is wider than a word), yet not
// into the next label's: the layout keeps labels at least twice LABEL_PAD apart.
const LABEL_PAD = 4; // graph units (pt)
function padLabel(edge) {
  const text = edge.querySelector("text");
  if (!text) return;
  const b = text.getBBox(); // laid out: the svg is in the page
  const rect = document.createElementNS("http://www.w3.org/2000/svg", "rect");
  rect.setAttribute("class", "label-hit");
  rect.setAttribute("x", b.x - LABEL_PAD);
  rect.setAttribute("y", b.y - LABEL_PAD);
  rect.setAttribute("width", b.width + 2 * LABEL_PAD);
  rect.setAttribute("height", b.height + 2 * LABEL_PAD);
  rect.setAttribute("rx", LABEL_PAD);
  text.before(rect);
}

function renderActive() {
  const active = latest.smach_active?.msg;
  renderSide(active);
  if (!drawn) return;
  for (const el of box.querySelectorAll(".active, .current, .available, .clickable")) {
    el.classList.remove("active", "current", "available", "clickable", "sending");
    el.removeAttribute("tabindex");
    el.removeAttribute("role");
    el.removeAttribute("aria-label");
  }
  if (!active) return;
  for (const path of active.active) {
    drawn.nodes.get(path)?.classList.add("active");
    drawn.clusters.get(path)?.classList.add("active");
  }
  for (const path of active.leaves) drawn.nodes.get(path)?.classList.add("current");
  requestAnimationFrame(showCurrent);
  for (const t of active.transitions) {
    for (const e of drawn.edges) {
      if (e.from !== t.from || e.event !== t.event) continue;
      e.el.classList.add("available");
      if (canCommand) {
        e.el.classList.add("clickable");
        e.el.setAttribute("tabindex", "0");
        e.el.setAttribute("role", "button");
        e.el.setAttribute("aria-label", `Send event ${t.event} (to ${nameOf(t.to)})`);
      }
    }
  }
}

// The side panel: where the robot is and the events it accepts there, also without a graph.
function renderSide(active) {
  const change = latest.state_change?.msg;
  let current = change?.to_system_state || "—", chain = current, offers = [];
  if (active?.leaves.length) {
    current = active.leaves.map(nameOf).join(", ");
    chain = active.active.map(nameOf).join(" › ");
    offers = active.transitions.map((t) => ({ event: t.event, to: nameOf(t.to) }));
  } else if (latest.state_transitions) { // no introspection: what the robot itself says is on offer
    try {
      offers = Object.entries(JSON.parse(latest.state_transitions.msg.data || "{}")).map(([event, to]) => ({ event, to }));
    } catch { offers = []; }
  }
  set("smach.current", current);
  set("smach.chain", chain);
  set("smach.event", change?.event || "—");
  const source = active?.source;
  set("smach.source", source === "introspection" ? "live from SMACH introspection"
    : source === "state_change" ? "from state changes (no introspection)" : "");
  const seen = new Set();
  const buttons = offers.filter((o) => !seen.has(o.event) && seen.add(o.event)).map((o) => {
    const b = document.createElement("button");
    b.type = "button";
    b.className = "btn event-btn";
    b.dataset.event = o.event;
    b.disabled = !canCommand;
    b.textContent = `${o.event} → ${o.to}`;
    return b;
  });
  if (buttons.length) eventsBox.replaceChildren(...buttons);
  else eventsBox.textContent = "No events known from this state.";
}

async function send(event, edge = null) {
  edge?.classList.add("sending");
  await sendCommand("event", { event }, { result: resultLine });
  edge?.classList.remove("sending");
}

box.addEventListener("click", (ev) => {
  const edge = ev.target.closest("g.edge.clickable");
  if (edge) send(edge.dataset.event, edge);
});
box.addEventListener("keydown", (ev) => {
  const edge = ev.target.closest?.("g.edge.clickable");
  if (edge && (ev.key === "Enter" || ev.key === " ")) { ev.preventDefault(); send(edge.dataset.event, edge); }
});
eventsBox.addEventListener("click", (ev) => {
  const button = ev.target.closest("button[data-event]");
  if (button && !button.disabled) send(button.dataset.event);
});
document.getElementById("smach-zoom").addEventListener("click", (ev) => {
  const fit = box.classList.toggle("fit");
  ev.currentTarget.setAttribute("aria-pressed", String(fit));
});

// At its own size the graph scrolls; keep the current state in view when it moves, with the
// labels of its transitions when they fit beside it (on a phone they often do not).
function showCurrent() {
  const el = box.querySelector("g.node.current");
  if (!el || box.classList.contains("fit")) return;
  const b = box.getBoundingClientRect();
  let a = el.getBoundingClientRect();
  const labels = [...box.querySelectorAll("g.edge.available .label-hit")].map((r) => r.getBoundingClientRect());
  const all = [a, ...labels].reduce((u, r) => ({
    left: Math.min(u.left, r.left), right: Math.max(u.right, r.right),
    top: Math.min(u.top, r.top), bottom: Math.max(u.bottom, r.bottom),
  }));
  if (all.right - all.left <= b.width && all.bottom - all.top <= b.height) a = all;
  if (a.left < b.left || a.right > b.right || a.top < b.top || a.bottom > b.bottom) {
    box.scrollBy({ left: (a.left + a.right - b.left - b.right) / 2, top: (a.top + a.bottom - b.top - b.bottom) / 2 });
  }
}

// A robot without SMACH introspection never sends a graph: say so, the panel beside still works.
const NO_GRAPH_AFTER_S = 15;
setTimeout(() => {
  if (!drawn && !drawing) {
    set("smach.waiting", "The robot has not sent its state machine's structure (SMACH introspection): "
      + "the current state and the events it accepts are listed beside, from its state changes.");
  }
}, NO_GRAPH_AFTER_S * 1000);

function tickAge() {
  const el = document.querySelector('[data-age="smach_active"]');
  const frame = latest.smach_active ?? latest.state_change;
  el.textContent = frame ? `in this state for ${formatElapsed(Date.now() / 1000 - frame.t)}` : "";
}
setInterval(tickAge, 1000);

live.watch(config.keys, (frame) => {
  latest[frame.key] = frame;
  if (frame.key === "smach_graph") {
    if (frame.msg.version !== drawing?.version) drawGraph(frame.msg);
  } else renderActive();
  tickAge();
});
