"""What differs between the ROS 1 and the ROS 2 rosbridge on the wire, as one table per ROS.

The nodes build every message the ROS 1 way (``{secs, nsecs}`` stamps, headers with ``seq``,
two-part schema names); a ``Dialect`` turns that into what the robot's rosbridge sends
(ROBOT_INTERFACE.md, "ROS 2 robots") and takes both spellings in.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from robot import interface as ri

from . import messages

_TYPE_RE = {ri.ROS1: re.compile(r"^[A-Za-z]\w*/[A-Za-z]\w*$"),
            ri.ROS2: re.compile(r"^[A-Za-z]\w*/(?:(?:msg|srv|action)/)?[A-Za-z]\w*$")}
_SEQ = re.compile(r'"seq":-?\d+,')


@dataclass(frozen=True)
class Dialect:
    ros: int

    @property
    def ros2(self) -> bool:
        return self.ros == ri.ROS2

    def valid_type(self, type_name: str) -> bool:
        return bool(_TYPE_RE[self.ros].match(type_name))

    def spell(self, type_name: str, kind: str = "msg") -> str:
        """A type as this ROS's rosbridge names it."""
        return ri.ros2_spelling(type_name, kind) if self.ros2 else type_name

    def encode(self, frame: dict[str, Any]) -> str:
        text = messages.encode(frame)
        if not self.ros2:
            return text
        # builtin_interfaces/Time and a Header without seq; a key inside a string value is escaped (\")
        return _SEQ.sub("", text.replace('"secs":', '"sec":').replace('"nsecs":', '"nanosec":'))

    def log(self, level: int, node: str, text: str) -> dict[str, Any]:
        """/rosout's message; ``level`` in ROS 1's scale (1 DEBUG .. 16 FATAL)."""
        if self.ros2:
            return {"stamp": messages.stamp(), "level": 10 * level.bit_length(), "name": node.lstrip("/"),
                    "msg": text, "file": "sim.py", "function": "", "line": 0}
        return {"header": messages.header(), "level": level, "name": node, "msg": text, "file": "sim.py",
                "function": "", "line": 0, "topics": ["/rosout"]}

    def particles(self, header: dict[str, Any], poses: list[dict[str, Any]]) -> dict[str, Any]:
        """amcl's cloud: a PoseArray on ROS 1, nav2_msgs/ParticleCloud on ROS 2."""
        if self.ros2:
            weight = 1.0 / max(1, len(poses))
            return {"header": header, "particles": [{"pose": p, "weight": weight} for p in poses]}
        return {"header": header, "poses": poses}


ROS1 = Dialect(ri.ROS1)
ROS2 = Dialect(ri.ROS2)
DIALECTS = {ri.ROS1: ROS1, ri.ROS2: ROS2}
