// Map metres <-> image pixels <-> screen, the browser twin of robot/navigation/transforms.py.
// Image pixels: (0,0) is the image's top-left corner; the grid's row 0 is the image's
// bottom row (ROS y up, image y down). Screen = CSS pixels of the map viewport.

export function mapToPixel(meta, x, y) {
  const { origin, resolution, height } = meta;
  const dx = x - origin.x, dy = y - origin.y;
  const c = Math.cos(origin.yaw || 0), s = Math.sin(origin.yaw || 0);
  const col = (c * dx + s * dy) / resolution;
  const row = (-s * dx + c * dy) / resolution;
  return [col, height - row];
}

export function pixelToMap(meta, px, py) {
  const { origin, resolution, height } = meta;
  const u = px * resolution, v = (height - py) * resolution;
  const c = Math.cos(origin.yaw || 0), s = Math.sin(origin.yaw || 0);
  return [origin.x + c * u - s * v, origin.y + s * u + c * v];
}

// Zoom and pan: screen = pixel * scale + offset.
export class View {
  constructor() { this.scale = 1; this.tx = 0; this.ty = 0; this.meta = null; }

  toScreen(x, y) {
    const [px, py] = mapToPixel(this.meta, x, y);
    return [px * this.scale + this.tx, py * this.scale + this.ty];
  }

  toMap(sx, sy) {
    return pixelToMap(this.meta, (sx - this.tx) / this.scale, (sy - this.ty) / this.scale);
  }

  // Screen length of `metres` at the current zoom.
  metres(m) { return (m / this.meta.resolution) * this.scale; }

  fit(width, height) {
    const { width: w, height: h } = this.meta;
    this.scale = Math.min(width / w, height / h) * 0.96;
    this.tx = (width - w * this.scale) / 2;
    this.ty = (height - h * this.scale) / 2;
  }

  zoomAt(sx, sy, factor) {
    const minScale = 0.02, maxScale = 40;
    const next = Math.min(maxScale, Math.max(minScale, this.scale * factor));
    const f = next / this.scale;
    this.tx = sx - (sx - this.tx) * f;
    this.ty = sy - (sy - this.ty) * f;
    this.scale = next;
  }

  panBy(dx, dy) { this.tx += dx; this.ty += dy; }

  // The heading (map frame, radians, CCW from +x) of a screen drag from a to b.
  headingOf(ax, ay, bx, by) {
    const [x0, y0] = this.toMap(ax, ay);
    const [x1, y1] = this.toMap(bx, by);
    return Math.atan2(y1 - y0, x1 - x0);
  }
}

// A round length (1, 2 or 5 × 10^k metres) that is between minPx and 2.5 × minPx on screen.
export function scaleBar(view, minPx = 60) {
  const perPixel = 1 / view.metres(1);
  const raw = minPx * perPixel;
  const power = 10 ** Math.floor(Math.log10(raw));
  const metres = [1, 2, 5, 10].map((k) => k * power).find((m) => m >= raw);
  return { metres, px: view.metres(metres) };
}

export function formatMetres(m) {
  if (m >= 1000) return `${m / 1000} km`;
  if (m >= 1) return `${m} m`;
  return `${Math.round(m * 100)} cm`;
}

export function quaternionToYaw(q) {
  if (!q) return 0;
  const { x = 0, y = 0, z = 0, w = 1 } = q;
  return Math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
}
