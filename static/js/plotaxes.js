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
