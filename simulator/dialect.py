"""What differs between the ROS 1 and the ROS 2 rosbridge on the wire, as one table per ROS.

The nodes build every message the ROS 1 way (``{secs, nsecs}`` stamps, headers with ``seq``,
two-part schema names); a ``Dialect`` turns that into what the robot's rosbridge sends
(ROBOT_INTERFACE.md, "ROS 2 robots") and takes both spellings in. That includes what Foxglove and
Lichtblick ask for: full definitions (``/rosapi/topics_and_raw_types``, gendeps' ``--cat`` layout) and
``cbor-raw`` frames with the message in the robot's own serialization (ROS 1's, or CDR on ROS 2),
written by rosbags from its type stores, not by the product's serializer, so the two check each other.
"""

from __future__ import annotations

import base64
import re
import time
from dataclasses import dataclass
from typing import Any

import cbor2
import numpy as np
from rosbags.interfaces import Nodetype

from robot import interface as ri

from . import messages

_TYPE_RE = {ri.ROS1: re.compile(r"^[A-Za-z]\w*/[A-Za-z]\w*$"),
            ri.ROS2: re.compile(r"^[A-Za-z]\w*/(?:(?:msg|srv|action)/)?[A-Za-z]\w*$")}
_SEQ = re.compile(r'"seq":-?\d+,')
_DTYPES = {"byte": np.int8, "char": np.uint8}


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

    def full_text(self, msg_type: str) -> str:
        """The definition with every type it uses after it, as rosapi gives it (empty if unknown)."""
        store, name = messages.STORES[self.ros], messages.store_name(msg_type)
        return store.generate_msgdef(name, ros_version=self.ros)[0] if name in store.fielddefs else ""

    def raw_frame(self, topic: str, msg_type: str, msg: dict[str, Any]) -> bytes:
        """rosbridge's ``cbor-raw`` publish frame: receive time and the serialized message."""
        store, name = messages.STORES[self.ros], messages.store_name(msg_type)
        value = _build(store, name, msg)
        raw = store.serialize_cdr(value, name) if self.ros2 else store.serialize_ros1(value, name)
        secs, nsecs = divmod(time.time_ns(), 1_000_000_000)
        return cbor2.dumps({"op": "publish", "topic": topic,
                            "msg": {"secs": secs, "nsecs": nsecs, "bytes": bytes(raw)}})


def _build(store: Any, name: str, value: Any) -> Any:
    """The rosbags message of ``value`` (rosbridge JSON in either spelling; missing fields take defaults)."""
    value = value if isinstance(value, dict) else {}
    if name in ("builtin_interfaces/msg/Time", "builtin_interfaces/msg/Duration"):
        return store.types[name](sec=int(value.get("secs", value.get("sec", 0))),
                                 nanosec=int(value.get("nsecs", value.get("nanosec", 0))))
    return store.types[name](**{f: _field(store, desc, value.get(f)) for f, desc in store.fielddefs[name][1]})


def _field(store: Any, desc: tuple[Any, Any], value: Any) -> Any:
    kind, detail = desc
    if kind == Nodetype.NAME:
        return _build(store, detail, value)
    if kind == Nodetype.BASE:
        base = detail[0]
        if base in ("string", "bool"):
            return str(value or "") if base == "string" else bool(value)
        return (float("nan") if value is None else float(value)) if base.startswith("float") else int(value or 0)
    item = detail[0]
    if item[0] == Nodetype.BASE and item[1][0] != "string":
        dtype = _DTYPES.get(item[1][0], np.dtype(item[1][0]))
        if isinstance(value, str):  # uint8[] / char[] as base64
            return np.frombuffer(base64.b64decode(value), dtype=dtype)
        return np.array([np.nan if v is None else v for v in value or ()], dtype=dtype)
    return [_field(store, item, v) for v in value or ()]


ROS1 = Dialect(ri.ROS1)
ROS2 = Dialect(ri.ROS2)
DIALECTS = {ri.ROS1: ROS1, ri.ROS2: ROS2}
