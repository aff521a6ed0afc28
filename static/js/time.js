// One time policy for every page: times are shown in the site's time zone (settings.TIME_ZONE),
// labelled with its abbreviation, as 2026-05-04 14:03:07; APIs and exports carry UTC.
import { site } from "./config.js";

export const zone = site.time_zone || "UTC";

const formatter = new Intl.DateTimeFormat("en-GB", {
  timeZone: zone, year: "numeric", month: "2-digit", day: "2-digit",
  hour: "2-digit", minute: "2-digit", second: "2-digit", hourCycle: "h23", timeZoneName: "short",
});

// Seconds since the epoch, a Date or milliseconds (≥ 1e11) → Date.
function toDate(t) {
  if (t instanceof Date) return t;
  return new Date(t >= 1e11 ? t : t * 1000);
}

function parts(t) {
  const out = {};
  for (const p of formatter.formatToParts(toDate(t))) out[p.type] = p.value;
  return out;
}

// "2026-05-04 14:03:07" (date: false → "14:03:07"; seconds: false drops them; label adds "CEST").
export function formatTime(t, { date = true, seconds = true, label = false } = {}) {
  const p = parts(t);
  let text = `${p.hour}:${p.minute}${seconds ? `:${p.second}` : ""}`;
  if (date) text = `${p.year}-${p.month}-${p.day} ${text}`;
  return label ? `${text} ${p.timeZoneName}` : text;
}

// The zone's abbreviation at that instant ("CET", "CEST", "UTC").
export function zoneLabel(t = new Date()) { return parts(t).timeZoneName; }

// The zone's offset from UTC in seconds at instant t.
function offsetAt(t) {
  const p = parts(t);
  const asUTC = Date.UTC(+p.year, +p.month - 1, +p.day, +p.hour % 24, +p.minute, +p.second);
  return (asUTC - Math.floor(toDate(t).getTime() / 1000) * 1000) / 1000;
}

// "2026-05-04 14:03[:07]" read in the site's zone → seconds since the epoch (NaN if not a time).
export function parseSiteTime(text) {
  const m = /^\s*(\d{4})-(\d{2})-(\d{2})[ T](\d{2}):(\d{2})(?::(\d{2}))?\s*$/.exec(text || "");
  if (!m) return NaN;
  const [y, mo, d, h, mi, s] = m.slice(1).map((v) => Number(v || 0));
  if (mo < 1 || mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 || s > 59) return NaN;
  const naive = Date.UTC(y, mo - 1, d, h, mi, s) / 1000;
  const guess = naive - offsetAt(naive);
  return naive - offsetAt(guess); // second pass lands right across a DST change
}

// Seconds since the epoch → the text parseSiteTime reads back ("2026-05-04 14:03").
export function toSiteInput(t) { return formatTime(t, { seconds: false }); }

export function formatAge(seconds) {
  if (seconds == null || !isFinite(seconds)) return "never";
  if (seconds < 1.5) return "just now";
  if (seconds < 90) return `${Math.round(seconds)} s ago`;
  if (seconds < 5400) return `${Math.round(seconds / 60)} min ago`;
  return `${Math.round(seconds / 3600)} h ago`;
}

// How long something has lasted, to the whole second: "8 s", "12 min", "3 h".
export function formatElapsed(seconds) {
  const s = Math.max(0, seconds || 0);
  if (s < 90) return `${Math.round(s)} s`;
  if (s < 5400) return `${Math.round(s / 60)} min`;
  return `${Math.round(s / 3600)} h`;
}

export function formatDuration(s) {
  if (s < 90) return `${s.toFixed(1)} s`;
  if (s < 5400) return `${(s / 60).toFixed(1)} min`;
  return `${(s / 3600).toFixed(2)} h`;
}
