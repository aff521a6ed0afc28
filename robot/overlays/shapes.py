"""The small overlays as the map page draws them: flat lists of map-frame coordinates.

Each function takes a robot message and where its frame is on the map, and returns the
message the page gets: numbers rounded to a centimetre (or a hundredth of a radian), so a
541-beam scan is ~6 kB of JSON rather than the ~20 kB the robot sent.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from robot.overlays.frames import Pose2D, frame_name

MAX_PARTICLES = 2000  # AMCL may keep up to 5000: more dots than a page needs to show the spread
MAX_PATH_POSES = 500


def stamp_seconds(header: Any) -> float | None:
    stamp = (header or {}).get("stamp") if isinstance(header, dict) else None
    if not isinstance(stamp, dict):
        return None
    try:
        return float(stamp.get("secs", 0)) + float(stamp.get("nsecs", 0)) / 1e9
    except (TypeError, ValueError):
        return None


def _flat(xy: np.ndarray, digits: int = 2) -> list[float]:
    return [float(v) for v in np.round(xy, digits).ravel()]


def scan_points(scan: dict[str, Any], laser: Pose2D) -> dict[str, Any]:
    """A ``sensor_msgs/LaserScan`` as map points: ``{"origin": [x, y], "points": [x0, y0, x1, y1, …]}``.

    Beams without a return (``null`` on the wire for NaN/Inf, or outside range_min..range_max)
    are left out.
    """
    raw = scan.get("ranges") or []
    ranges = np.array([np.nan if r is None else r for r in raw], dtype=np.float64)
    n = ranges.size
    angle_min = float(scan.get("angle_min") or 0.0)
    increment = float(scan.get("angle_increment") or 0.0)
    lo, hi = float(scan.get("range_min") or 0.0), float(scan.get("range_max") or math.inf)
    with np.errstate(invalid="ignore"):
        hit = np.isfinite(ranges) & (ranges >= lo) & (ranges <= hi)
    angles = laser.yaw + angle_min + increment * np.arange(n)
    r = ranges[hit]
    xs = laser.x + r * np.cos(angles[hit])
    ys = laser.y + r * np.sin(angles[hit])
    return {"origin": _flat(np.array([laser.x, laser.y])), "points": _flat(np.column_stack((xs, ys))),
            "beams": int(n), "range_max": hi if math.isfinite(hi) else None}


def cloud_points(cloud: dict[str, Any], sensor: Pose2D) -> dict[str, Any]:
    """A ``sensor_msgs/PointCloud`` (the sonar ring's echoes) as map points, with where the sensor
    is: ``{"origin": [x, y], "yaw": yaw, "points": [x0, y0, …], "ranges": [r0, …]}``."""
    rows, ranges = [], []
    for p in cloud.get("points") or []:
        try:
            x, y = float(p["x"]), float(p["y"])
        except (KeyError, TypeError, ValueError):
            continue
        if not (math.isfinite(x) and math.isfinite(y)):
            continue
        rows.append(sensor.apply(x, y))
        ranges.append(math.hypot(x, y))
    return {"origin": _flat(np.array([sensor.x, sensor.y])), "yaw": round(sensor.yaw, 3),
            "points": _flat(np.array(rows, dtype=np.float64).reshape(-1, 2)), "ranges": _flat(np.array(ranges))}


def _poses(poses: list[dict[str, Any]], frame: Pose2D, limit: int) -> np.ndarray:
    if len(poses) > limit:
        poses = poses[:: math.ceil(len(poses) / limit)]
    rows = []
    for p in poses:
        try:
            local = Pose2D.from_pose(p)
        except (AttributeError, ValueError):
            continue
        g = frame.compose(local)
        rows.append((g.x, g.y, math.atan2(math.sin(g.yaw), math.cos(g.yaw))))
    return np.array(rows, dtype=np.float64).reshape(-1, 3)


def particle_poses(cloud: dict[str, Any], frame: Pose2D) -> dict[str, Any]:
    """A ``geometry_msgs/PoseArray`` as ``{"poses": [x0, y0, yaw0, …], "count": n}`` (at most MAX_PARTICLES)."""
    poses = cloud.get("poses") or []
    return {"poses": _flat(_poses(poses, frame, MAX_PARTICLES)), "count": len(poses)}


def path_points(path: dict[str, Any], frame: Pose2D) -> dict[str, Any]:
    """A ``nav_msgs/Path`` as ``{"points": [x0, y0, …]}``; each pose's own header is ignored (as RViz does)."""
    poses = [p.get("pose") or {} for p in path.get("poses") or [] if isinstance(p, dict)]
    return {"points": _flat(_poses(poses, frame, MAX_PATH_POSES)[:, :2])}


def polygon_points(polygon: dict[str, Any], frame: Pose2D) -> dict[str, Any]:
    """A ``geometry_msgs/PolygonStamped`` as ``{"points": [x0, y0, …]}``."""
    rows = []
    for p in (polygon.get("polygon") or {}).get("points") or []:
        try:
            rows.append(frame.apply(float(p["x"]), float(p["y"])))
        except (KeyError, TypeError, ValueError):
            continue
    return {"points": _flat(np.array(rows, dtype=np.float64).reshape(-1, 2))}


def header_frame(msg: dict[str, Any]) -> str:
    return frame_name((msg.get("header") or {}).get("frame_id"))
