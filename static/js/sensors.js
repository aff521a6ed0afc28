// The dashboard's sensors card: the robot seen from above (forward is up) with its bumper
// segments (red while pressed) and its sonar echoes, and a one-line diagnostics summary.
const SVG = "http://www.w3.org/2000/svg";
const VIEW_M = 3; // metres shown ahead, behind and to each side
const BODY_R = 0.38;

function svgEl(name, attrs) {
  const el = document.createElementNS(SVG, name);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, v);
  return el;
}

// Robot frame (x forward, y left) → the drawing (forward up).
const toView = (x, y) => [-y, -x];

function arc(r, from, to) {
  const [x0, y0] = toView(r * Math.cos(from), r * Math.sin(from));
  const [x1, y1] = toView(r * Math.cos(to), r * Math.sin(to));
  return `M ${x0.toFixed(3)} ${y0.toFixed(3)} A ${r} ${r} 0 0 1 ${x1.toFixed(3)} ${y1.toFixed(3)}`;
}

export class SensorsCard {
  constructor(root) {
    this.root = root;
    this.svg = root.querySelector(".sensors-view");
    this.bumpers = svgEl("g", { class: "bumpers" });
    this.echoes = svgEl("g", { class: "echoes" });
    this.svg.append(
      svgEl("circle", { class: "ring", cx: 0, cy: 0, r: 1 }), svgEl("circle", { class: "ring", cx: 0, cy: 0, r: 2 }),
      svgEl("circle", { class: "body", cx: 0, cy: 0, r: BODY_R }),
      svgEl("path", { class: "body", d: `M 0 ${-BODY_R - 0.12} l 0.1 0.16 h -0.2 z` }),
      this.echoes, this.bumpers,
    );
    this.set = (name, text) => root.querySelectorAll(`[data-field="${name}"]`).forEach((el) => { el.textContent = text; });
  }

  // bumper_state: {front_bumpers: [bool], rear_bumpers: [bool]}; returns the pressed sides.
  showBumpers(m) {
    const sides = { front: m.front_bumpers || [], rear: m.rear_bumpers || [] };
    const paths = [];
    for (const [side, flags] of Object.entries(sides)) {
      const centre = side === "front" ? 0 : Math.PI, span = Math.PI * 0.8, step = span / Math.max(flags.length, 1);
      flags.forEach((pressed, i) => {
        // Segment 0 on the robot's right, as seen from above.
        const a = centre - span / 2 + i * step;
        paths.push(svgEl("path", { class: `bumper${pressed ? " pressed" : ""}`, d: arc(BODY_R + 0.1, a + 0.03, a + step - 0.03),
          "data-side": side, "data-pressed": String(Boolean(pressed)) }));
      });
    }
    this.bumpers.replaceChildren(...paths);
    const pressed = Object.entries(sides).filter(([, flags]) => flags.some(Boolean)).map(([side]) => side);
    this.set("bumpers.state", pressed.length ? `${pressed.join(" and ")} pressed` : "clear");
    this.root.querySelector('[data-field="bumpers.state"]')?.classList.toggle("result-bad", pressed.length > 0);
    return pressed;
  }

  // overlay_sonar: echoes placed on the map, with where the ring is; drawn around the ring.
  showSonar(m) {
    if (m.problem || !m.points) { this.set("sonar.nearest", m.problem || "—"); return; }
    const c = Math.cos(-m.yaw), s = Math.sin(-m.yaw);
    const marks = [];
    for (let i = 0; i < m.points.length; i += 2) {
      const dx = m.points[i] - m.origin[0], dy = m.points[i + 1] - m.origin[1];
      let x = c * dx - s * dy, y = s * dx + c * dy;
      const r = Math.hypot(x, y);
      if (r > VIEW_M) { x *= VIEW_M / r; y *= VIEW_M / r; }
      const [vx, vy] = toView(x, y);
      marks.push(svgEl("line", { class: "beam", x1: 0, y1: 0, x2: vx.toFixed(3), y2: vy.toFixed(3) }));
      if (r <= VIEW_M) marks.push(svgEl("circle", { class: "echo", cx: vx.toFixed(3), cy: vy.toFixed(3), r: 0.07 }));
    }
    this.echoes.replaceChildren(...marks);
    this.set("sonar.nearest", m.ranges.length ? `${Math.min(...m.ranges).toFixed(2)} m` : "no echo");
  }

  showDiagnostics(summary) {
    const counts = {};
    for (const c of summary.components) counts[c.level_name] = (counts[c.level_name] ?? 0) + 1;
    const text = Object.entries(counts).map(([level, n]) => `${n} ${level}`).join(", ");
    this.set("diagnostics.summary", text || "no components reported");
  }
}
