// How far the robot still has to go to its goal, and about how long that takes: along the planned
// path from the point nearest the robot (straight to the goal when there is no plan), at the speed
// the robot has been closing in over the last seconds.

const WINDOW_S = 10; // the speed is the distance covered over this long
const MIN_SPEED = 0.02; // m/s: slower than this is standing, no estimate

// Metres left from the robot to the goal along plan ([[x, y], …], ending at the goal).
export function distanceLeft(robot, goal, plan) {
  if (!robot || !goal || goal.x == null) return null;
  const straight = Math.hypot(goal.x - robot.x, goal.y - robot.y);
  if (!plan?.length) return straight;
  let nearest = 0, best = Infinity;
  plan.forEach(([x, y], i) => {
    const d = Math.hypot(x - robot.x, y - robot.y);
    if (d < best) { best = d; nearest = i; }
  });
  let along = best;
  for (let i = nearest + 1; i < plan.length; i++) along += Math.hypot(plan[i][0] - plan[i - 1][0], plan[i][1] - plan[i - 1][1]);
  const [lx, ly] = plan[plan.length - 1];
  along += Math.hypot(goal.x - lx, goal.y - ly); // a plan that stops short of the goal
  return along;
}

export class Progress {
  #samples = []; // [t, metres left]
  #goalId = null;

  // Note the distance left at time t (s); returns {metres, seconds} (seconds null while unknown).
  update(goalId, metres, t) {
    if (goalId !== this.#goalId) { this.#goalId = goalId; this.#samples = []; }
    if (metres == null) return { metres: null, seconds: null };
    this.#samples.push([t, metres]);
    while (this.#samples.length > 2 && t - this.#samples[0][0] > WINDOW_S) this.#samples.shift();
    const [t0, m0] = this.#samples[0];
    const speed = t > t0 ? (m0 - metres) / (t - t0) : 0;
    return { metres, seconds: speed >= MIN_SPEED ? metres / speed : null };
  }
}

export function formatLeft({ metres, seconds }) {
  if (metres == null) return "—";
  const distance = metres < 10 ? `${metres.toFixed(1)} m` : `${Math.round(metres)} m`;
  if (seconds == null) return `${distance} to go`;
  const time = seconds < 90 ? `${Math.round(seconds)} s` : `${Math.round(seconds / 60)} min`;
  return `${distance} to go · about ${time}`;
}
