"""The simulated world: occupancy maps, named locations, A* planning, the base's physics, and the message
shapes several nodes build from them (a pose in the map, a tf transform, an occupancy grid)."""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.ndimage import distance_transform_edt

from robot import interface as ri

from . import messages

RESOLUTION = 0.05  # m/cell, like the Cyborg's gmapping maps
ROBOT_RADIUS = 0.2  # m, footprint used for collisions (the Pioneer LX is ~0.35 m, we are generous)
INFLATION = 0.35  # m, planner clearance
UNKNOWN, FREE, OCCUPIED = -1, 0, 100
_RING = [(math.cos(a), math.sin(a)) for a in (2 * math.pi * k / 12 for k in range(12))]


@dataclass(frozen=True)
class Location:
    name: str
    x: float
    y: float
    yaw: float
    threshold: float = 0.5  # m: "at" this location within this radius


@dataclass
class WorldMap:
    name: str
    grid: np.ndarray  # int8, shape (height, width), row 0 at origin y
    resolution: float
    origin_x: float
    origin_y: float
    locations: dict[str, Location]
    start: tuple[float, float, float]

    @property
    def width(self) -> int:
        return int(self.grid.shape[1])

    @property
    def height(self) -> int:
        return int(self.grid.shape[0])

    def blocks(self, f: int, fill: int) -> np.ndarray:
        """The grid as f x f blocks, shape (rows, f, cols, f); cells past its edges are ``fill``."""
        h, w = -(-self.height // f), -(-self.width // f)
        grid = np.full((h * f, w * f), fill, dtype=np.int8)
        grid[:self.height, :self.width] = self.grid
        return grid.reshape(h, f, w, f)

    def cell(self, x: float, y: float) -> tuple[int, int]:
        return int((y - self.origin_y) / self.resolution), int((x - self.origin_x) / self.resolution)

    def occupied(self, x: float, y: float) -> bool:
        r, c = self.cell(x, y)
        if not (0 <= r < self.height and 0 <= c < self.width):
            return True
        return int(self.grid[r, c]) != FREE

    def footprint_free(self, x: float, y: float, radius: float = ROBOT_RADIUS) -> bool:
        ring = ((x + radius * cx, y + radius * sy) for cx, sy in _RING)
        return not self.occupied(x, y) and not any(self.occupied(px, py) for px, py in ring)

    def fan(self, body: Base, mount_x: float, fov: float, beams: int, max_range: float) -> list[tuple[float, float]]:
        """(angle from the heading, range) of ``beams`` rays spread over ``fov`` from a sensor
        mounted ``mount_x`` ahead of the body's centre."""
        x, y = body.x + mount_x * math.cos(body.yaw), body.y + mount_x * math.sin(body.yaw)
        angles = [-fov / 2 + i * fov / (beams - 1) for i in range(beams)]
        return [(a, self.raycast(x, y, body.yaw + a, max_range)) for a in angles]

    def raycast(self, x: float, y: float, angle: float, max_range: float = 5.0) -> float:
        step = self.resolution
        dx, dy = math.cos(angle) * step, math.sin(angle) * step
        d = 0.0
        while d < max_range:
            x += dx
            y += dy
            d += step
            if self.occupied(x, y):
                return d
        return max_range


def glassgarden() -> WorldMap:
    """A 20 x 15 m hall (400 x 300 cells) loosely after Glassgården: glass-roofed atrium, pillars,
    a café and meeting rooms along the north wall, the entrance in the south wall, unknown outside."""
    res, ox, oy = RESOLUTION, -10.0, -7.5
    grid = np.full((300, 400), UNKNOWN, dtype=np.int8)

    def rect(x0: float, y0: float, x1: float, y1: float, v: int) -> None:
        c0, c1 = int((x0 - ox) / res), math.ceil((x1 - ox) / res)
        r0, r1 = int((y0 - oy) / res), math.ceil((y1 - oy) / res)
        grid[max(r0, 0):max(r1, 0), max(c0, 0):max(c1, 0)] = v

    rect(-9.5, -7.0, 9.5, 7.0, OCCUPIED)  # outer wall band ...
    rect(-9.35, -6.85, 9.35, 6.85, FREE)  # ... hollowed out: 15 cm walls
    rect(-1.0, -7.0, 1.0, -6.85, FREE)  # entrance door, south wall
    rect(-1.0, -7.5, 1.0, -7.0, FREE)  # the porch in front of it
    # North rooms (café, meeting room, elevator lobby) separated from the hall by a wall with doors.
    rect(-9.35, 3.5, 9.35, 3.65, OCCUPIED)
    for x in (-6.5, -0.5, 5.5):
        rect(x, 3.5, x + 1.2, 3.65, FREE)
    for x in (-3.0, 3.0):
        rect(x, 3.65, x + 0.15, 6.85, OCCUPIED)
    # Pillars of the atrium: 2 rows of 4, 40 x 40 cm.
    for px in (-6.0, -2.0, 2.0, 6.0):
        for py in (-3.0, 1.0):
            rect(px - 0.2, py - 0.2, px + 0.2, py + 0.2, OCCUPIED)
    # Café counter and a few benches.
    rect(-8.5, 5.8, -5.0, 6.2, OCCUPIED)
    rect(-5.0, -5.5, -3.0, -5.2, OCCUPIED)
    rect(3.0, -5.5, 5.0, -5.2, OCCUPIED)
    locations = {loc.name: loc for loc in (
        Location("entrance", 0.0, -6.0, math.pi / 2),
        Location("reception", 0.0, -1.0, -math.pi / 2),
        Location("cafe", -6.5, 5.0, math.pi / 2),
        Location("meeting_room", 0.0, 5.2, math.pi / 2),
        Location("elevator", 6.5, 5.2, math.pi / 2),
        Location("stage", 6.5, -1.0, 0.0),
        Location("charging_station", -8.3, -6.0, math.pi),
    )}
    return WorldMap("glassgarden", grid, res, ox, oy, locations, start=(0.0, -1.0, math.pi / 2))


def large(seed: int = 0) -> WorldMap:
    """A 200 x 200 m floor (4000 x 4000 cells) for benchmarks: a grid of halls and pillars."""
    res, ox, oy = RESOLUTION, -100.0, -100.0
    n = 4000
    grid = np.zeros((n, n), dtype=np.int8)
    grid[:3, :] = grid[-3:, :] = grid[:, :3] = grid[:, -3:] = OCCUPIED
    rng = np.random.default_rng(seed)
    for k in range(400, n, 400):  # walls every 20 m with two doors each
        grid[k:k + 3, :] = OCCUPIED
        grid[:, k:k + 3] = OCCUPIED
        for j in range(0, n, 400):
            for off in (rng.integers(40, 160), rng.integers(240, 360)):
                grid[k:k + 3, j + off:j + off + 40] = FREE
                grid[j + off:j + off + 40, k:k + 3] = FREE
    pillars = rng.integers(10, n - 20, size=(800, 2))
    for r, c in pillars:
        grid[r:r + 8, c:c + 8] = OCCUPIED
    locations = {}
    for name, (x, y) in {"entrance": (-95.0, -95.0), "charging_station": (-97.0, -90.0), "center": (10.0, 10.0),
                         "far_corner": (95.0, 95.0)}.items():
        r, c = int((y - oy) / res), int((x - ox) / res)
        grid[r - 20:r + 20, c - 20:c + 20] = FREE
        locations[name] = Location(name, x, y, 0.0)
    return WorldMap("large", grid, res, ox, oy, locations, start=(-95.0, -95.0, 0.0))


def build(name: str, seed: int = 0) -> WorldMap:
    if name == "glassgarden":
        return glassgarden()
    if name == "large":
        return large(seed)
    raise ValueError(f"unknown map {name!r} (glassgarden, large)")


class Planner:
    """A* on a coarse costmap: cells with anything but free space are lethal, cells within
    the inflation radius cost more (so a robot already near a wall can still leave)."""

    def __init__(self, world: WorldMap) -> None:
        self.world = world
        # glassgarden: 0.1 m cells; large: 0.5 m cells, to keep the search small
        f = max(2, math.ceil(math.sqrt(world.width * world.height / 160_000)))
        h, w = world.height // f, world.width // f
        blocks = world.grid[: h * f, : w * f].reshape(h, f, w, f)
        lethal = (blocks != FREE).any(axis=(1, 3))
        self.res = world.resolution * f
        rad = max(1, (math.ceil(INFLATION / self.res)))
        # Within rad cells (Euclidean) of a lethal cell; a map without any has nothing to inflate.
        inflated = distance_transform_edt(~lethal) <= rad if lethal.any() else lethal
        self.cost = np.where(lethal, -1, np.where(inflated, 12, 1)).astype(np.int16)
        self.h, self.w = h, w

    def to_cell(self, x: float, y: float) -> tuple[int, int]:
        return int((y - self.world.origin_y) / self.res), int((x - self.world.origin_x) / self.res)

    def plan(self, start: tuple[float, float], goal: tuple[float, float]) -> list[tuple[float, float]] | None:
        sr, sc = self.to_cell(*start)
        gr, gc = self.to_cell(*goal)
        h, w = self.h, self.w
        if not (0 <= gr < h and 0 <= gc < w and 0 <= sr < h and 0 <= sc < w) or self.cost[gr, gc] < 0:
            return None
        cost = self.cost.tolist()
        sq2 = math.sqrt(2.0)
        moves = [(-1, 0, 1.0), (1, 0, 1.0), (0, -1, 1.0), (0, 1, 1.0),
                 (-1, -1, sq2), (-1, 1, sq2), (1, -1, sq2), (1, 1, sq2)]

        def heuristic(r: int, c: int) -> float:
            dr, dc = abs(r - gr), abs(c - gc)
            return (dr + dc) + (sq2 - 2) * min(dr, dc)

        best = {(sr, sc): 0.0}
        came: dict[tuple[int, int], tuple[int, int]] = {}
        frontier = [(heuristic(sr, sc), 0.0, sr, sc)]
        while frontier:
            _, g, r, c = heapq.heappop(frontier)
            if (r, c) == (gr, gc):
                break
            if g > best.get((r, c), math.inf):
                continue
            for dr, dc, step in moves:
                nr, nc = r + dr, c + dc
                if not (0 <= nr < h and 0 <= nc < w):
                    continue
                k = cost[nr][nc]
                if k < 0 or (dr and dc and (cost[r][nc] < 0 or cost[nr][c] < 0)):
                    continue
                ng = g + step * k
                if ng < best.get((nr, nc), math.inf):
                    best[(nr, nc)] = ng
                    came[(nr, nc)] = (r, c)
                    heapq.heappush(frontier, (ng + heuristic(nr, nc), ng, nr, nc))
        else:
            return None
        cells = [(gr, gc)]
        while cells[-1] != (sr, sc):
            cells.append(came[cells[-1]])
        cells.reverse()
        ox, oy = self.world.origin_x, self.world.origin_y
        return [start] + [(ox + (c + 0.5) * self.res, oy + (r + 0.5) * self.res) for r, c in cells[1:-1]] + [goal]


def wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def yaw_to_quaternion(yaw: float) -> dict[str, float]:
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}


def quaternion_to_yaw(q: dict[str, float]) -> float:
    x, y, z, w = q.get("x", 0.0), q.get("y", 0.0), q.get("z", 0.0), q.get("w", 1.0)
    if x == y == z == w == 0.0:  # the ROS default quaternion: treat as no rotation
        return 0.0
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


@dataclass
class Base:
    """The Pioneer LX base: a unicycle that stops 0.5 s after the last command."""

    world: WorldMap
    x: float
    y: float
    yaw: float
    v: float = 0.0
    w: float = 0.0
    cmd_v: float = 0.0
    cmd_w: float = 0.0
    cmd_time: float = -math.inf
    motors: bool = True
    bumped: bool = False
    odom_x: float = 0.0
    odom_y: float = 0.0
    odom_yaw: float = 0.0

    MAX_V = 1.8
    MAX_W = 2.5
    CMD_TIMEOUT = 0.5

    def command(self, v: float, w: float, now: float) -> None:
        self.cmd_v = max(-self.MAX_V, min(self.MAX_V, v))
        self.cmd_w = max(-self.MAX_W, min(self.MAX_W, w))
        self.cmd_time = now

    def step(self, dt: float, now: float) -> bool:
        """Advance dt seconds; return True if the robot bumped into something this step."""
        if not self.motors or now - self.cmd_time > self.CMD_TIMEOUT:
            self.v = self.w = 0.0
        else:
            self.v, self.w = self.cmd_v, self.cmd_w
        if self.v == 0.0 and self.w == 0.0:
            self.bumped = False
            return False
        mid = self.yaw + self.w * dt / 2
        nx = self.x + self.v * math.cos(mid) * dt
        ny = self.y + self.v * math.sin(mid) * dt
        self.yaw = wrap(self.yaw + self.w * dt)
        self.odom_yaw = wrap(self.odom_yaw + self.w * dt)
        if self.v != 0.0 and not self.world.footprint_free(nx, ny):
            if self.world.footprint_free(self.x, self.y):
                self.v = 0.0
                newly = not self.bumped
                self.bumped = True
                return newly
            # already touching something: allow only moves that do not go deeper
            if self._clearance(nx, ny) < self._clearance(self.x, self.y):
                self.v = 0.0
                return False
        d = math.hypot(nx - self.x, ny - self.y)
        self.odom_x += math.copysign(d, self.v) * math.cos(self.odom_yaw)
        self.odom_y += math.copysign(d, self.v) * math.sin(self.odom_yaw)
        self.x, self.y = nx, ny
        self.bumped = False
        return False

    def _clearance(self, x: float, y: float) -> float:
        return min(self.world.raycast(x, y, a, 1.0) for a in np.linspace(0, 2 * math.pi, 8, endpoint=False))

    def map_from_odom(self) -> tuple[float, float, float]:
        """Where odometry's frame is on the map: whatever makes map -> odom -> base_link the true pose."""
        dyaw = wrap(self.yaw - self.odom_yaw)
        c, s = math.cos(dyaw), math.sin(dyaw)
        return self.x - (c * self.odom_x - s * self.odom_y), self.y - (s * self.odom_x + c * self.odom_y), dyaw

    def teleport(self, x: float, y: float, yaw: float) -> None:
        self.x, self.y, self.yaw = x, y, wrap(yaw)
        self.v = self.w = self.cmd_v = self.cmd_w = 0.0


def pose(x: float, y: float, yaw: float) -> dict[str, Any]:
    return {"position": {"x": x, "y": y, "z": 0.0}, "orientation": yaw_to_quaternion(yaw)}


def body_pose(b: Base) -> dict[str, Any]:
    return pose(b.x, b.y, b.yaw)


def transform(parent: str, child: str, x: float, y: float, yaw: float) -> dict[str, Any]:
    return {"header": messages.header(parent), "child_frame_id": child,
            "transform": {"translation": {"x": x, "y": y, "z": 0.0}, "rotation": yaw_to_quaternion(yaw)}}


def grid(data: list[int], width: int, height: int, res: float, ox: float, oy: float,
         load_time: dict[str, int], frame: str = ri.MAP_FRAME) -> dict[str, Any]:
    return {"header": messages.header(frame), "info": {
        "map_load_time": load_time, "resolution": res, "width": width, "height": height,
        "origin": pose(ox, oy, 0.0)}, "data": data}
