// What the replay shows at a moment, from a seek (the state at the window's start) and the window's
// changes: the latest value of each topic at or before t, found by binary search (changes are in time order).

export function lastAtOrBefore(items, t, time = (item) => item[0]) {
  let lo = 0, hi = items.length - 1, found = -1;
  while (lo <= hi) {
    const mid = (lo + hi) >> 1;
    if (time(items[mid]) <= t) { found = mid; lo = mid + 1; } else hi = mid - 1;
  }
  return found;
}

export class Timeline {
  constructor(seek, window) {
    this.seek = seek;
    this.start = window.start;
    this.end = window.start;
    this.poses = []; this.changes = []; this.log = []; this.commands = []; this.frames = []; this.maps = [];
    this.extend(window);
  }

  extend(window) {
    if (window.start !== this.end) return false;  // only a window that continues this one
    this.poses.push(...window.poses);
    this.changes.push(...window.changes);
    this.log.push(...window.log);
    this.commands.push(...window.commands);
    this.frames.push(...window.frames);
    this.maps.push(...window.maps.filter(Boolean));
    this.end = window.end;
    return true;
  }

  covers(t) { return t >= this.start && t <= this.end; }

  at(t) {
    const topics = { ...this.seek.topics };
    const n = lastAtOrBefore(this.changes, t);
    const seen = new Set();
    for (let i = n; i >= 0 && seen.size < 16; i--) {
      const [ct, key, msg] = this.changes[i];
      if (!seen.has(key)) { seen.add(key); topics[key] = { t: ct, msg }; }
    }
    const p = lastAtOrBefore(this.poses, t);
    const pose = p >= 0 ? this.poses[p] : this.seek.pose;
    const trail = [...this.seek.trail, ...this.poses.slice(0, p + 1)].filter((q) => q[0] >= t - 60);
    const f = lastAtOrBefore(this.frames, t);
    const frame = f >= 0 ? { id: this.frames[f][1], t: this.frames[f][0], url: this.frames[f][2] } : this.seek.frame;
    const m = lastAtOrBefore(this.maps, t, (item) => item.t || 0);
    const byTime = (item) => item.t;
    const log = [...this.seek.log, ...this.log.slice(0, lastAtOrBefore(this.log, t, byTime) + 1)].slice(-30);
    const commands = [...this.seek.commands, ...this.commands.slice(0, lastAtOrBefore(this.commands, t, byTime) + 1)]
      .slice(-20);
    return { t, topics, pose, trail, frame, map: m >= 0 ? this.maps[m] : this.seek.map, log, commands, goal: goalOf(topics, t) };
  }
}

// The goal being driven to: the end of a fresh plan while move_base has an active goal.
export function goalOf(topics, t) {
  const plan = topics.plan, status = topics.move_base_status;
  if (!plan || t - plan.t > 30) return null;
  const active = ((status && status.msg.status_list) || []).some((s) => s.status === 1);
  const poses = plan.msg.poses || [];
  if (!active || !poses.length) return null;
  const end = (poses[poses.length - 1].pose || {}).position || {};
  return { x: end.x || 0, y: end.y || 0 };
}
