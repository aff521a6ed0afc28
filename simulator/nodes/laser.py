"""RosAria's laser (a SICK S300 on the Pioneer LX): ranges ray-cast against the world's grid.

All beams are cast at once with numpy, sphere-tracing through a distance map of the
world (scipy's Euclidean distance transform, computed once): in open space a beam leaps
as far as the nearest obstacle allows, near obstacles it walks cell by cell, so a scan
takes tens of steps rather than one per cell and still never skips a corner. A beam's
range is where it first enters an occupied cell; beams that see nothing in range are NaN
(``null`` on the wire, as rosbridge sends them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from scipy.ndimage import distance_transform_edt

from .. import messages
from ..bus import Bus, SimNode
from ..world import FREE, OCCUPIED, Base, WorldMap

MAX_STEPS = 1000  # enough for a beam grazing a wall all the way to range_max
MOUNT = (0.2, 0.0, 0.0)  # x, y, yaw of the laser on base_link (the /tf_static the base publishes)


@dataclass
class Laser(SimNode):
    """The laser (``body``: the base it sits on) publishes a scan at ``rate_hz`` while anyone subscribes."""

    world: WorldMap
    body: Base | None = None
    rate_hz: float = 10.0
    beams: int = 541
    angle_min: float = -0.75 * math.pi
    angle_max: float = 0.75 * math.pi
    range_min: float = 0.05
    range_max: float = 10.0
    mount: tuple[float, float, float] = MOUNT
    publishes = ("scan",)  # RosAria publishes it (the base node names /RosAria)

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.every(1.0 / self.rate_hz, self._publish, wanted="scan")

    def _publish(self) -> None:
        assert self.body is not None
        b = self.body
        self.bus.publish("scan", self.message(b.x, b.y, b.yaw, scan_time=1.0 / self.rate_hz))

    @cached_property
    def _tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """Built on first use, as the distance map costs a moment: the beams' angles, the occupied
        cells, and per block of f x f cells the metres from its centre to the nearest occupied block's
        centre, less twice a block's half diagonal (from anywhere in one block to anywhere in the
        other): never more than the way is clear. Blocks keep a large map quick."""
        occupied = self.world.grid >= OCCUPIED
        f = max(1, math.ceil(math.sqrt(occupied.size / 250_000)))
        blocks = (self.world.blocks(f, FREE) >= OCCUPIED).any(axis=(1, 3))
        size = f * self.world.resolution
        clearance = (distance_transform_edt(~blocks) * size - size * 1.5).astype(np.float32)
        return self.angle_min + self.angle_increment * np.arange(self.beams), occupied, clearance, f

    @property
    def angle_increment(self) -> float:
        return (self.angle_max - self.angle_min) / (self.beams - 1)

    def pose_on(self, x: float, y: float, yaw: float) -> tuple[float, float, float]:
        """Where the laser is when the base is at (x, y, yaw)."""
        mx, my, myaw = self.mount
        c, s = math.cos(yaw), math.sin(yaw)
        return x + c * mx - s * my, y + s * mx + c * my, yaw + myaw

    def ranges(self, x: float, y: float, yaw: float) -> np.ndarray:
        """Ranges (m, NaN for no return) of every beam for a base at (x, y, yaw) on the map."""
        w = self.world
        res = w.resolution
        beam_angles, occupied, clearance_map, block = self._tables
        lx, ly, lyaw = self.pose_on(x, y, yaw)
        angles = lyaw + beam_angles
        dx, dy = np.cos(angles), np.sin(angles)
        with np.errstate(divide="ignore"):
            inv_x, inv_y = np.where(dx != 0, 1 / dx, np.inf), np.where(dy != 0, 1 / dy, np.inf)
        out = np.full(self.beams, np.nan)
        travelled = np.zeros(self.beams)
        active = np.arange(self.beams)
        for _ in range(MAX_STEPS):
            if active.size == 0:
                break
            d = travelled[active]
            px, py = lx + dx[active] * d - w.origin_x, ly + dy[active] * d - w.origin_y
            cols, rows = np.floor(px / res).astype(np.int64), np.floor(py / res).astype(np.int64)
            inside = (rows >= 0) & (rows < w.height) & (cols >= 0) & (cols < w.width) & (d <= self.range_max)
            rows, cols = np.where(inside, rows, 0), np.where(inside, cols, 0)
            hit = inside & occupied[rows, cols]
            out[active[hit]] = np.maximum(d[hit], self.range_min)  # d is where the beam entered this cell
            # Far from obstacles, leap by the clearance; near them, step into the next cell the beam
            # crosses (a grid traversal), so no corner is ever skipped.
            clearance = clearance_map[rows // block, cols // block]
            ix, iy = inv_x[active], inv_y[active]
            to_x = ((cols + (ix > 0)) * res - px) * ix
            to_y = ((rows + (iy > 0)) * res - py) * iy
            travelled[active] = d + np.maximum(clearance, np.minimum(to_x, to_y) + 1e-6)
            active = active[inside & ~hit]
        return out

    def message(self, x: float, y: float, yaw: float, frame: str = "laser", scan_time: float = 0.1) -> dict[str, Any]:
        """A ``sensor_msgs/LaserScan`` for a base at (x, y, yaw), stamped once its sweep is done."""
        ranges = self.ranges(x, y, yaw)
        return {
            "header": messages.header(frame), "angle_min": self.angle_min, "angle_max": self.angle_max,
            "angle_increment": self.angle_increment, "time_increment": 0.0, "scan_time": scan_time,
            "range_min": self.range_min, "range_max": self.range_max,
            "ranges": [None if math.isnan(r) else round(float(r), 3) for r in ranges],
            "intensities": [],
        }
