// Map overlays: laser scan, costmaps, particles, footprint, local plan. Each is switched on and
// off by the person (remembered on the server), watched on the live socket only while on, and
// drawn on the map's overlay canvas in map coordinates the server already placed.
import { live } from "../live.js";

export const OVERLAYS = [
  { name: "global_costmap", label: "Global costmap", costmap: true },
  { name: "local_costmap", label: "Local costmap", costmap: true },
  { name: "particles", label: "Particle cloud" },
  { name: "local_plan", label: "Local plan" },
  { name: "footprint", label: "Footprint" },
  { name: "scan", label: "Laser scan" },
  { name: "sonar", label: "Sonar" },
];
// The laser in a hue the costmaps never use (they run blue → red, cyan, magenta), ringed dark so it
// stands out on free, occupied and costly cells alike.
const COLORS = { sonar: "#1f8f86", scan: "#ffd400", particles: "#7a3fc4", footprint: "#0b7d4f", local_plan: "#13a34a" };
const DOT_EDGE = "#1c2433";
// robot/overlays/costmap.py's palette: cost from blue to red, inscribed cyan, lethal magenta.
const COSTMAP_SWATCH = "linear-gradient(90deg, rgb(40 90 230), rgb(255 0 0) 55%, rgb(0 200 230) 56% 77%, rgb(170 0 170) 78%)";

// The legend's swatch: the very colour the overlay is drawn in.
export function swatchFill(name) {
  return OVERLAYS.find((o) => o.name === name)?.costmap ? COSTMAP_SWATCH : COLORS[name];
}

// One costmap layer: tiles loaded per revision; a tile keeps the placement it was fetched for,
// so a rolling costmap never draws old cells at the new origin.
class CostmapLayer {
  constructor(onLoad) { this.tiles = new Map(); this.meta = null; this.onLoad = onLoad; }

  update(meta) {
    this.meta = meta;
    if (!meta.origin) return;
    const wanted = new Set();
    meta.tiles.forEach((row, r) => row.forEach((rev, c) => {
      const id = `${r}-${c}`;
      wanted.add(id);
      let entry = this.tiles.get(id);
      if (!entry) this.tiles.set(id, (entry = { r, c }));
      const want = `${meta.version}/${rev}`;
      if (entry.shown === want) { entry.meta = meta; return; } // same cells, maybe a new placement
      if (entry.want === want) return; // on its way
      entry.want = want;
      const img = new Image();
      img.onload = () => {
        if (entry.want !== want) return; // a newer revision was asked for meanwhile
        Object.assign(entry, { img, meta, shown: want });
        this.onLoad();
      };
      img.src = `${meta.url}${id}-${rev}.png`;
    }));
    for (const id of [...this.tiles.keys()]) if (!wanted.has(id)) this.tiles.delete(id);
  }

  draw(ctx, view, dpr) {
    ctx.save();
    ctx.imageSmoothingEnabled = false;
    for (const tile of this.tiles.values()) {
      if (!tile.img) continue;
      const m = tile.meta, o = m.origin;
      // image pixel -> map: the image's row 0 is the costmap's top row.
      const toMap = (px, py) => {
        const u = px * m.resolution, v = (m.height - py) * m.resolution;
        const c = Math.cos(o.yaw), s = Math.sin(o.yaw);
        return [o.x + c * u - s * v, o.y + s * u + c * v];
      };
      const [x0, y0] = view.toScreen(...toMap(0, 0));
      const [x1, y1] = view.toScreen(...toMap(1, 0));
      const [x2, y2] = view.toScreen(...toMap(0, 1));
      ctx.setTransform(dpr * (x1 - x0), dpr * (y1 - y0), dpr * (x2 - x0), dpr * (y2 - y0), dpr * x0, dpr * y0);
      ctx.drawImage(tile.img, tile.c * m.tile, tile.r * m.tile);
    }
    ctx.restore();
  }

  clear() { this.tiles.clear(); this.meta = null; }
}

export class Overlays {
  // enabled: {name: bool}; save(name, on) persists a choice; redraw() asks the page to draw.
  constructor({ enabled, save, redraw }) {
    this.enabled = { ...enabled };
    this.save = save;
    this.redraw = redraw;
    this.data = {};
    this.stops = {};
    this.costmaps = {
      global_costmap: new CostmapLayer(redraw),
      local_costmap: new CostmapLayer(redraw),
    };
    for (const o of OVERLAYS) if (this.enabled[o.name]) this.#watch(o.name);
  }

  #watch(name) {
    this.stops[name] = live.watch([`overlay_${name}`], (frame) => {
      if (!this.enabled[name]) return;
      this.data[name] = frame.msg;
      if (this.costmaps[name]) this.costmaps[name].update(frame.msg);
      this.redraw();
    });
  }

  async toggle(name, on) {
    if (Boolean(this.enabled[name]) === on) return;
    this.enabled[name] = on;
    if (on) this.#watch(name);
    else {
      this.stops[name]?.();
      delete this.stops[name];
      delete this.data[name];
      this.costmaps[name]?.clear();
    }
    this.redraw();
    await this.save(name, on);
  }

  // A short line per overlay for the legend: what it shows, or why nothing.
  describe(name) {
    const m = this.data[name];
    if (!this.enabled[name]) return "";
    if (!m) return "waiting for the robot…";
    if (m.problem) return m.problem;
    if (name === "scan") return `${m.points.length / 2} of ${m.beams} beams`;
    if (name === "particles") return `${m.count} particles`;
    if (name === "sonar") return m.ranges.length ? `${m.ranges.length} echoes, nearest ${Math.min(...m.ranges).toFixed(2)} m` : "no echoes";
    if (name === "local_plan") return `${m.points.length / 2} poses`;
    if (name === "footprint") return `${m.points.length / 2} corners`;
    if (this.costmaps[name]) {
      return m.origin ? `${m.width} × ${m.height} cells · ${m.resolution} m` : `waiting for where ${m.frame} is on the map`;
    }
    return "";
  }

  // Costmaps first (under everything), the rest later (drawOver), so the robot stays on top of the cells.
  drawUnder(ctx, view, dpr) {
    for (const name of ["global_costmap", "local_costmap"]) {
      if (this.enabled[name]) this.costmaps[name].draw(ctx, view, dpr);
    }
  }

  drawOver(ctx, view) {
    const d = this.data;
    if (this.enabled.particles && d.particles?.poses) drawParticles(ctx, view, d.particles.poses);
    if (this.enabled.local_plan && d.local_plan?.points) polyline(ctx, view, d.local_plan.points, COLORS.local_plan, 3, false);
    if (this.enabled.footprint && d.footprint?.points) polyline(ctx, view, d.footprint.points, COLORS.footprint, 2, true);
    if (this.enabled.scan && d.scan?.points) drawPoints(ctx, view, d.scan.points, COLORS.scan);
    if (this.enabled.sonar && d.sonar?.points) drawBeams(ctx, view, d.sonar.origin, d.sonar.points, COLORS.sonar);
  }
}

function drawPoints(ctx, view, flat, color) {
  const r = Math.max(2, Math.min(3.5, view.metres(0.03)));
  ctx.fillStyle = color;
  ctx.strokeStyle = DOT_EDGE;
  ctx.lineWidth = 1;
  ctx.beginPath();
  for (let i = 0; i < flat.length; i += 2) {
    const [sx, sy] = view.toScreen(flat[i], flat[i + 1]);
    ctx.moveTo(sx + r, sy);
    ctx.arc(sx, sy, r, 0, 2 * Math.PI);
  }
  ctx.fill();
  ctx.stroke();
}

// Each echo as a dot on a faint line from the sensor: a sonar ring has few, wide beams.
function drawBeams(ctx, view, origin, flat, color) {
  const [ox, oy] = view.toScreen(origin[0], origin[1]);
  ctx.strokeStyle = color; ctx.globalAlpha = 0.35; ctx.lineWidth = 1.5;
  ctx.beginPath();
  for (let i = 0; i < flat.length; i += 2) {
    const [sx, sy] = view.toScreen(flat[i], flat[i + 1]);
    ctx.moveTo(ox, oy); ctx.lineTo(sx, sy);
  }
  ctx.stroke();
  ctx.globalAlpha = 1;
  drawPoints(ctx, view, flat, color);
}

function drawParticles(ctx, view, flat) {
  const len = Math.max(6, Math.min(14, view.metres(0.25)));
  ctx.strokeStyle = COLORS.particles; ctx.lineWidth = 1.2;
  ctx.beginPath();
  for (let i = 0; i < flat.length; i += 3) {
    const [sx, sy] = view.toScreen(flat[i], flat[i + 1]);
    const yaw = flat[i + 2];
    ctx.moveTo(sx, sy);
    ctx.lineTo(sx + Math.cos(yaw) * len, sy - Math.sin(yaw) * len);
  }
  ctx.stroke();
}

function polyline(ctx, view, flat, color, width, closed) {
  if (flat.length < 4) return;
  ctx.strokeStyle = color; ctx.lineWidth = width; ctx.lineJoin = "round";
  ctx.beginPath();
  for (let i = 0; i < flat.length; i += 2) {
    const [sx, sy] = view.toScreen(flat[i], flat[i + 1]);
    if (i) ctx.lineTo(sx, sy); else ctx.moveTo(sx, sy);
  }
  if (closed) ctx.closePath();
  ctx.stroke();
}
