// The live overlay: costmaps and sensor overlays, locations, planned path, goal, robot, and the arrow being dragged.

const COLORS = {
  robot: "#1f8f86", robotEdge: "#0b4f4a", plan: "#2f6fd6", goal: "#d9822b", done: "#1f8f4e",
  failed: "#c0392b", location: "#6b4fbb", pose: "#b7791f", label: "#1c2433",
};

function arrow(ctx, sx, sy, heading, length, color, width = 3) {
  // heading is in map radians (CCW); screen y is down, so negate the angle.
  const ex = sx + Math.cos(heading) * length, ey = sy - Math.sin(heading) * length;
  ctx.strokeStyle = color; ctx.fillStyle = color; ctx.lineWidth = width; ctx.lineCap = "round";
  ctx.beginPath(); ctx.moveTo(sx, sy); ctx.lineTo(ex, ey); ctx.stroke();
  const a = Math.atan2(ey - sy, ex - sx), h = Math.max(7, width * 3);
  ctx.beginPath();
  ctx.moveTo(ex, ey);
  ctx.lineTo(ex - h * Math.cos(a - 0.45), ey - h * Math.sin(a - 0.45));
  ctx.lineTo(ex - h * Math.cos(a + 0.45), ey - h * Math.sin(a + 0.45));
  ctx.closePath(); ctx.fill();
}

function dot(ctx, sx, sy, r, fill, stroke = "#fff") {
  ctx.beginPath(); ctx.arc(sx, sy, r, 0, Math.PI * 2);
  ctx.fillStyle = fill; ctx.fill();
  ctx.lineWidth = 2; ctx.strokeStyle = stroke; ctx.stroke();
}

function label(ctx, sx, sy, text) {
  ctx.font = "600 12px system-ui, sans-serif";
  ctx.lineWidth = 3; ctx.strokeStyle = "rgba(255,255,255,.9)"; ctx.fillStyle = COLORS.label;
  ctx.strokeText(text, sx + 8, sy - 8); ctx.fillText(text, sx + 8, sy - 8);
}

function drawLocations(ctx, view, locations, current) {
  for (const loc of locations) {
    const [sx, sy] = view.toScreen(loc.x, loc.y);
    const r = Math.max(3, view.metres(loc.threshold || 0));
    ctx.beginPath(); ctx.arc(sx, sy, r, 0, Math.PI * 2);
    ctx.fillStyle = loc.name === current ? "rgba(107,79,187,.22)" : "rgba(107,79,187,.10)"; ctx.fill();
    dot(ctx, sx, sy, 4, COLORS.location);
    label(ctx, sx, sy, loc.name);
  }
}

function drawPlan(ctx, view, plan) {
  if (!plan || plan.length < 2) return;
  ctx.strokeStyle = COLORS.plan; ctx.lineWidth = 3; ctx.lineJoin = "round"; ctx.setLineDash([8, 6]);
  ctx.beginPath();
  plan.forEach(([x, y], i) => { const [sx, sy] = view.toScreen(x, y); i ? ctx.lineTo(sx, sy) : ctx.moveTo(sx, sy); });
  ctx.stroke(); ctx.setLineDash([]);
}

function drawGoal(ctx, view, goal) {
  if (!goal || goal.x == null) return;  // another tool's goal: the robot's status does not say where
  const color = goal.status === "succeeded" ? COLORS.done
    : ["aborted", "rejected", "lost", "cancelled"].includes(goal.status) ? COLORS.failed : COLORS.goal;
  const [sx, sy] = view.toScreen(goal.x, goal.y);
  if (goal.finished) ctx.globalAlpha = 0.5;
  dot(ctx, sx, sy, 6, color);
  arrow(ctx, sx, sy, goal.yaw, 26, color);
  ctx.globalAlpha = 1;
}

// A pressed bumper as a red arc on the robot's front or rear (bumper_state: one flag per segment).
function drawBumpers(ctx, r, bumpers) {
  const sides = [[bumpers?.front_bumpers, 0], [bumpers?.rear_bumpers, Math.PI]];
  ctx.strokeStyle = COLORS.failed; ctx.lineWidth = Math.max(3, r * 0.3); ctx.lineCap = "round";
  for (const [flags, centre] of sides) {
    if (!flags?.length) continue;
    const span = Math.PI * 0.8, step = span / flags.length;
    flags.forEach((pressed, i) => {
      if (!pressed) return;
      // Segments run from the robot's right to its left (screen angles: y down, so negate).
      const a = centre - span / 2 + i * step;
      ctx.beginPath(); ctx.arc(0, 0, r * 1.45, -(a + step) + 0.04, -a - 0.04); ctx.stroke();
    });
  }
}

function drawRobot(ctx, view, robot, bumpers) {
  if (!robot) return;
  const [sx, sy] = view.toScreen(robot.x, robot.y);
  const r = Math.max(8, view.metres(0.3)); // the Pioneer LX is ~0.7 m long
  const a = -robot.yaw;
  ctx.save(); ctx.translate(sx, sy); ctx.rotate(a);
  ctx.beginPath();
  ctx.moveTo(r * 1.3, 0); ctx.lineTo(-r * 0.8, r * 0.8); ctx.lineTo(-r * 0.4, 0); ctx.lineTo(-r * 0.8, -r * 0.8);
  ctx.closePath();
  ctx.fillStyle = COLORS.robot; ctx.fill();
  ctx.lineWidth = 2; ctx.strokeStyle = COLORS.robotEdge; ctx.stroke();
  drawBumpers(ctx, r, bumpers);
  ctx.restore();
}

// s.overlays (map/overlays.js): costmaps under everything, sensor shapes over the path.
export function drawOverlay(ctx, view, s, dpr = 1) {
  ctx.clearRect(0, 0, ctx.canvas.width, ctx.canvas.height);
  if (!view.meta) return;
  s.overlays?.drawUnder(ctx, view, dpr);
  drawLocations(ctx, view, s.locations, s.currentLocation);
  drawPlan(ctx, view, s.plan);
  s.overlays?.drawOver(ctx, view);
  drawGoal(ctx, view, s.goal);
  drawRobot(ctx, view, s.robot, s.bumpers);
  if (s.drag) {
    const [sx, sy] = view.toScreen(s.drag.x, s.drag.y);
    const color = s.drag.mode === "pose" ? COLORS.pose : COLORS.goal;
    dot(ctx, sx, sy, 6, color);
    arrow(ctx, sx, sy, s.drag.yaw, 34, color, 4);
  }
}
