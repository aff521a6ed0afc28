// The diagnostics page: one row per component the robot reports on its diagnostics topic,
// with its level (coloured), message, key/values and how long ago it was heard from.
import { readConfig } from "./config.js";
import { live } from "./live.js";
import { formatAge } from "./time.js";

const config = readConfig("diagnostics-config");
const body = document.querySelector("#diagnostics-table tbody");
const overall = document.querySelector('[data-field="diagnostics.overall"]');
const LEVEL_CLASS = { 0: "ok", 1: "warn", 2: "error", 3: "stale" };
let summary = null;

function cell(text, className = "") {
  const td = document.createElement("td");
  if (className) td.className = className;
  if (text !== undefined) td.textContent = text;
  return td;
}

function row(c) {
  const tr = document.createElement("tr");
  tr.dataset.component = c.name;
  tr.dataset.level = c.level_name;
  const name = cell(c.name, "name-cell");
  if (c.hardware_id) {
    const hw = document.createElement("span");
    hw.className = "hw";
    hw.textContent = c.hardware_id;
    name.append(hw);
  }
  const level = cell(undefined, "level-cell");
  const pill = document.createElement("span");
  pill.className = `level level-${LEVEL_CLASS[c.level] ?? "stale"}`;
  pill.textContent = c.level_name;
  level.append(pill);
  const values = cell(undefined, "values-col");
  if (c.values.length) {
    const dl = document.createElement("dl");
    for (const [key, value] of c.values) {
      const dt = document.createElement("dt"), dd = document.createElement("dd");
      dt.textContent = key;
      dd.textContent = value;
      dl.append(dt, dd);
    }
    values.append(dl);
  }
  tr.append(name, level, cell(c.message, "message-cell"), values, cell("", "age-cell"));
  return tr;
}

function render() {
  if (!summary) return;
  if (!summary.components.length) return;
  body.replaceChildren(...summary.components.map(row));
  tickAges();
}

function tickAges() {
  if (!summary) return;
  const now = Date.now() / 1000;
  let stale = 0;
  for (const c of summary.components) {
    const tr = body.querySelector(`tr[data-component="${CSS.escape(c.name)}"]`);
    if (!tr) continue;
    const age = now - c.t;
    const old = age > config.stale_after_s;
    stale += old;
    tr.classList.toggle("is-stale", old);
    tr.querySelector(".age-cell").textContent = `${formatAge(age)}${old ? " (stale)" : ""}`;
  }
  const counts = {};
  for (const c of summary.components) counts[c.level_name] = (counts[c.level_name] ?? 0) + 1;
  const parts = Object.entries(counts).map(([level, n]) => `${n} ${level}`);
  overall.textContent = `${summary.components.length} components · ${parts.join(", ")}${stale ? ` · ${stale} not heard from lately` : ""}`;
}
setInterval(tickAges, 1000);

live.watch(config.keys, (frame) => {
  summary = frame.msg;
  render();
});
