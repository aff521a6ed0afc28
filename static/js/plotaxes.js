// Axes for every plot (uPlot): time in 24 hours in the site's zone, values with their unit.
import { formatTime } from "./time.js";

// The time axis: 24-hour, the site's zone, the date on the first tick and where the day changes.
export function timeTicks(u, splits, axisIdx, space, incr) {
  let day = null;
  return splits.map((t, i) => {
    const today = formatTime(t).slice(0, 10);
    const text = formatTime(t, { date: i === 0 || today !== day, seconds: incr < 60 });
    day = today;
    return text;
  });
}

export function valueLabel(fields, unit) {
  const what = fields.length === 1 ? fields[0] : "value";
  return unit ? `${what} (${unit})` : what;
}

// A field's unit from the server's table (history/plotunits.py unit_rules): {unit, scale} or null.
export function unitOf(rules, topic, field) {
  const known = rules?.topics?.[topic]?.[field];
  if (known) return known;
  const rule = (rules?.paths ?? []).find(([pattern]) => new RegExp(pattern).test(field));
  return rule ? { unit: rule[1], scale: 1 } : null;
}

// The value axis of several fields: "data (%)" or "x (m), linear.x (m/s)".
export function fieldsLabel(names, units) {
  const same = units.every((u) => u && u.unit === units[0]?.unit);
  if (same && units.length) return valueLabel(names, units[0].unit);
  return names.map((n, i) => (units[i] ? `${n} (${units[i].unit})` : n)).join(", ");
}
