// The replay's map: the recorded map image fitted to the canvas, the pose trail, the robot and its goal.

const images = new Map();

function image(url, redraw) {
  let img = images.get(url);
  if (!img) {
    img = new Image();
    img.onload = redraw;
    img.src = url;
    images.set(url, img);
  }
  return img.complete && img.naturalWidth ? img : null;
}

function viewOf(canvas, map, trail) {
  if (map) {
    const scale = Math.min(canvas.width / map.width, canvas.height / map.height);
    const offX = (canvas.width - map.width * scale) / 2, offY = (canvas.height - map.height * scale) / 2;
    return {
      scale, offX, offY,
      toScreen: (x, y) => [offX + ((x - map.origin.x) / map.resolution) * scale,
        offY + (map.height - (y - map.origin.y) / map.resolution) * scale],
      metres: (m) => (m / map.resolution) * scale,
    };
  }
  const xs = trail.map((p) => p[1]), ys = trail.map((p) => p[2]);
  const cx = xs.length ? (Math.min(...xs) + Math.max(...xs)) / 2 : 0, cy = ys.length ? (Math.min(...ys) + Math.max(...ys)) / 2 : 0;
  const px = 40;  // pixels per metre without a map
  return { toScreen: (x, y) => [canvas.width / 2 + (x - cx) * px, canvas.height / 2 - (y - cy) * px], metres: (m) => m * px };
}

export function drawMap(canvas, moment, redraw) {
  const ctx = canvas.getContext("2d");
  ctx.fillStyle = "#cdd2d9"; ctx.fillRect(0, 0, canvas.width, canvas.height);
  const view = viewOf(canvas, moment.map, moment.trail);
  const img = moment.map && image(moment.map.url, redraw);
  if (img) {
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(img, view.offX, view.offY, moment.map.width * view.scale, moment.map.height * view.scale);
  }
  if (moment.trail.length > 1) {
    ctx.strokeStyle = "rgba(31,143,134,.6)"; ctx.lineWidth = 2; ctx.beginPath();
    moment.trail.forEach(([, x, y], i) => { const [sx, sy] = view.toScreen(x, y); i ? ctx.lineTo(sx, sy) : ctx.moveTo(sx, sy); });
    ctx.stroke();
  }
  if (moment.goal) {
    const [gx, gy] = view.toScreen(moment.goal.x, moment.goal.y);
    ctx.fillStyle = "#d9822b"; ctx.beginPath(); ctx.arc(gx, gy, 6, 0, Math.PI * 2); ctx.fill();
  }
  if (moment.pose) {
    const [, x, y, yaw] = moment.pose;
    const [sx, sy] = view.toScreen(x, y);
    ctx.fillStyle = "#1f8f86"; ctx.strokeStyle = "#0b4f4a"; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.arc(sx, sy, Math.max(5, view.metres(0.25)), 0, Math.PI * 2); ctx.fill(); ctx.stroke();
    ctx.beginPath(); ctx.moveTo(sx, sy); ctx.lineTo(sx + Math.cos(yaw) * 18, sy - Math.sin(yaw) * 18); ctx.stroke();
    canvas.dataset.pose = `${x.toFixed(3)},${y.toFixed(3)}`;
  } else {
    canvas.dataset.pose = "";
  }
}
