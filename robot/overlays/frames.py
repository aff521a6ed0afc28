"""Planar transforms between the robot's frames, and where each frame is on the map.

Overlays are drawn in the map frame. The robot says where its base is on the map
(``robot_pose``), where its sensors sit on the base (``/tf_static``) and where odometry's
frame is on the map (``/tf``, map -> odom). ``FrameTree`` keeps the newest of each and
answers "where is frame F on the map" by walking F's parents up to the map, or up to the
base, whose map pose comes from ``robot_pose``. Everything is 2D (x, y, yaw): the robot
drives on a floor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from robot.navigation.transforms import quaternion_to_yaw


@dataclass(frozen=True)
class Pose2D:
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0

    def compose(self, other: Pose2D) -> Pose2D:
        """``other`` (given in this pose's frame) in the frame this pose is given in."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return Pose2D(self.x + c * other.x - s * other.y, self.y + s * other.x + c * other.y, self.yaw + other.yaw)

    def apply(self, x: float, y: float) -> tuple[float, float]:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return self.x + c * x - s * y, self.y + s * x + c * y

    @classmethod
    def from_pose(cls, pose: dict[str, Any]) -> Pose2D:
        """A ``geometry_msgs/Pose``."""
        p = pose.get("position") or {}
        return cls(_num(p.get("x")), _num(p.get("y")), quaternion_to_yaw(pose.get("orientation") or {}))

    @classmethod
    def from_transform(cls, transform: dict[str, Any]) -> Pose2D:
        """A ``geometry_msgs/Transform``."""
        t = transform.get("translation") or {}
        return cls(_num(t.get("x")), _num(t.get("y")), quaternion_to_yaw(transform.get("rotation") or {}))


IDENTITY = Pose2D()


def _num(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"not a finite number: {value!r}")
    return float(value)


def frame_name(frame: Any) -> str:
    """tf2 frame ids carry no leading slash; ROS 1 tf ids often do."""
    return str(frame or "").lstrip("/")


class FrameTree:
    def __init__(self, map_frame: str = "map", base_frames: tuple[str, ...] = ("base_link", "base_footprint")) -> None:
        self.map_frame = map_frame
        self.base_frames = base_frames
        self.parents: dict[str, tuple[str, Pose2D]] = {}  # child -> (parent, child's pose in the parent)
        self.robot: Pose2D | None = None  # the base on the map

    def set_robot_pose(self, pose: dict[str, Any]) -> None:
        self.robot = Pose2D.from_pose(pose)

    def add_transforms(self, msg: dict[str, Any]) -> None:
        """A ``tf2_msgs/TFMessage`` (from /tf or /tf_static)."""
        for item in msg.get("transforms") or []:
            try:
                parent = frame_name((item.get("header") or {}).get("frame_id"))
                child = frame_name(item.get("child_frame_id"))
                pose = Pose2D.from_transform(item.get("transform") or {})
            except (AttributeError, ValueError):
                continue
            if parent and child and parent != child:
                self.parents[child] = (parent, pose)

    def in_map(self, frame: str) -> Pose2D | None:
        """The pose of ``frame`` on the map, or None while something on the way is unknown."""
        frame = frame_name(frame) or self.map_frame
        pose = IDENTITY
        seen: set[str] = set()
        while frame != self.map_frame:
            if frame in self.base_frames:
                return None if self.robot is None else self.robot.compose(pose)
            if frame in seen or frame not in self.parents:
                return None
            seen.add(frame)
            frame, step = self.parents[frame]
            pose = step.compose(pose)
        return pose
