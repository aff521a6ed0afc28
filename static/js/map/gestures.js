// Pointer gestures on the map: wheel and pinch zoom, drag to pan, and in "goal" or
// "pose" mode press-drag-release to aim (press at the target, drag for the heading).

const CLICK_SLOP_PX = 6;

export function attachGestures(el, view, { getMode, onView, onHover, onAim, onRelease, onLeave }) {
  const pointers = new Map(); // pointerId -> {x, y}
  let aim = null; // {x, y} screen point where the aiming press began
  let pinch = null; // {dist, mx, my}

  const local = (ev) => {
    const r = el.getBoundingClientRect();
    return [ev.clientX - r.left, ev.clientY - r.top];
  };

  function pinchState() {
    const [a, b] = [...pointers.values()];
    return { dist: Math.hypot(a.x - b.x, a.y - b.y), mx: (a.x + b.x) / 2, my: (a.y + b.y) / 2 };
  }

  el.addEventListener("wheel", (ev) => {
    ev.preventDefault();
    const [sx, sy] = local(ev);
    const delta = ev.deltaMode === 1 ? ev.deltaY * 16 : ev.deltaY;
    view.zoomAt(sx, sy, Math.pow(1.0015, -delta));
    onView();
  }, { passive: false });

  el.addEventListener("pointerdown", (ev) => {
    const [x, y] = local(ev);
    try { el.setPointerCapture(ev.pointerId); } catch { /* pointer already gone */ }
    pointers.set(ev.pointerId, { x, y, button: ev.button });
    if (pointers.size === 2) { aim = null; onAim(null); pinch = pinchState(); return; }
    if (pointers.size === 1 && ev.button === 0 && getMode() !== "pan") aim = { x, y };
  });

  el.addEventListener("pointermove", (ev) => {
    const [x, y] = local(ev);
    onHover(x, y);
    const p = pointers.get(ev.pointerId);
    if (!p) return;
    const dx = x - p.x, dy = y - p.y;
    p.x = x; p.y = y;
    if (pointers.size === 2 && pinch) {
      const next = pinchState();
      view.panBy(next.mx - pinch.mx, next.my - pinch.my);
      if (pinch.dist > 0) view.zoomAt(next.mx, next.my, next.dist / pinch.dist);
      pinch = next;
      onView();
    } else if (aim) {
      onAim(aim, { x, y });
    } else if (pointers.size === 1) {
      view.panBy(dx, dy);
      onView();
    }
  });

  function end(ev, cancelled) {
    if (!pointers.has(ev.pointerId)) return;
    const [x, y] = local(ev);
    pointers.delete(ev.pointerId);
    if (pointers.size < 2) pinch = null;
    if (aim && pointers.size === 0) {
      const start = aim;
      aim = null;
      const dragged = Math.hypot(x - start.x, y - start.y) > CLICK_SLOP_PX;
      if (cancelled) onAim(null);
      else onRelease(start, { x, y }, dragged);
    }
  }
  el.addEventListener("pointerup", (ev) => end(ev, false));
  el.addEventListener("pointercancel", (ev) => end(ev, true));
  el.addEventListener("pointerleave", () => onLeave());
}
