// The dashboard's alert strip for diagnostics: a component reporting WARN, ERROR or STALE
// raises an alert that stays while it does, and clears when it recovers or is no longer reported.
const LEVELS = { 1: "warn", 2: "error", 3: "warn" };

export function diagnosticAlerts(alerts) {
  const raised = new Map(); // alert id -> level shown
  return (summary) => {
    const now = new Map();
    for (const c of summary.components ?? []) {
      const level = LEVELS[c.level];
      if (level) now.set(`diag-${c.name}`, { level, text: `${c.name}: ${c.level_name} · ${c.message || "no message"}` });
    }
    for (const [id, level] of raised) {
      if (now.get(id)?.level !== level) alerts.condition(id, false); // recovered, or its colour changes
    }
    raised.clear();
    for (const [id, { level, text }] of now) {
      alerts.condition(id, true, text, level);
      raised.set(id, level);
    }
  };
}
