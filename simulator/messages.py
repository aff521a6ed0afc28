"""Message schemas, rosbridge-style JSON conversion, and what differs between the ROS 1 and the ROS 2
rosbridge on the wire.

The standard ROS message definitions are rosbags' (ROS 1 Noetic's and ROS 2 Jazzy's type stores); the
Cyborg's own types and the few standard ones rosbags does not ship are written out below. Incoming
messages are validated and normalised the way rosbridge_library's ``message_conversion`` does it (ROS 1
branch): unknown keys and float-for-int values are rejected, ints are fine for floats, missing fields take
defaults, a ``header`` object without a stamp is stamped now, byte arrays travel as base64.

The nodes build every message the ROS 1 way (``{secs, nsecs}`` stamps, headers with ``seq``, two-part
schema names); a ``Dialect`` turns that into what the robot's rosbridge sends (ROBOT_INTERFACE.md, "ROS 2
robots") and takes both spellings in. That includes what Foxglove and Lichtblick ask for: full definitions
(``/rosapi/topics_and_raw_types``, gendeps' ``--cat`` layout) and ``cbor-raw`` frames with the message in
the robot's own serialization (ROS 1's, or CDR on ROS 2), written by rosbags from these type stores, not
by the product's serializer, so the two check each other.
"""

from __future__ import annotations

import base64
import json
import math
import re
import time
from dataclasses import dataclass
from typing import Any

import cbor2
import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from robot import interface as ri

# Types rosbags' stores lack, in the .msg syntax ("type name" pairs separated by ';').
_DEFS: dict[str, str] = {
    "audio_common_msgs/AudioData": "uint8[] data",
    "audio_common_msgs/AudioInfo": (
        "uint8 channels; uint32 sample_rate; string sample_format; uint32 bitrate; string coding_format"
    ),
    "map_msgs/OccupancyGridUpdate": (
        "std_msgs/Header header; int32 x; int32 y; uint32 width; uint32 height; int8[] data"
    ),
    "tf2_msgs/TFMessage": "geometry_msgs/TransformStamped[] transforms",
    "move_base_msgs/MoveBaseGoal": "geometry_msgs/PoseStamped target_pose",
    "move_base_msgs/MoveBaseResult": "",
    "move_base_msgs/MoveBaseFeedback": "geometry_msgs/PoseStamped base_position",
    "cyborg_navigation/NavigationGoal": "string order; string location_name",
    "cyborg_navigation/NavigationResult": "string status",
    "cyborg_navigation/NavigationFeedback": "string status",
    "cyborg_controller/SystemState": "string event; string from_system_state; string to_system_state",
    "cyborg_controller/EmotionalState": (
        "string from_emotional_state; string to_emotional_state; float32 current_pleasure; "
        "float32 current_arousal; float32 current_dominance"
    ),
    "cyborg_controller/EmotionalFeedback": "float32 delta_pleasure; float32 delta_arousal; float32 delta_dominance",
    "rosaria/BumperState": "std_msgs/Header header; bool[] front_bumpers; bool[] rear_bumpers",
    "smach_msgs/SmachContainerStatus": (
        "std_msgs/Header header; string path; string[] initial_states; string[] active_states; "
        "string local_data; string info"
    ),
    "smach_msgs/SmachContainerStructure": (
        "std_msgs/Header header; string path; string[] children; string[] internal_outcomes; "
        "string[] outcomes_from; string[] outcomes_to; string[] container_outcomes"
    ),
    "rosbridge_msgs/ConnectedClient": "string ip_address; time connection_time",
    "rosbridge_msgs/ConnectedClients": "rosbridge_msgs/ConnectedClient[] clients",
    "nav2_msgs/Particle": "geometry_msgs/Pose pose; float64 weight",
    "nav2_msgs/ParticleCloud": "std_msgs/Header header; nav2_msgs/Particle[] particles",
    "nav2_msgs/NavigateToPoseGoal": "geometry_msgs/PoseStamped pose; string behavior_tree",
    "nav2_msgs/NavigateToPoseResult": "uint16 error_code; string error_msg",
    "nav2_msgs/NavigateToPoseFeedback": (
        "geometry_msgs/PoseStamped current_pose; duration navigation_time; duration estimated_time_remaining; "
        "int16 number_of_recoveries; float32 distance_remaining"
    ),
    "rosapi/TypeDef": (
        "string type; string[] fieldnames; string[] fieldtypes; int32[] fieldarraylen; string[] examples; "
        "string[] constnames; string[] constvalues"
    ),
}

# actionlib wrappers, generated the way genaction does.
for _action in ("move_base_msgs/MoveBase", "cyborg_navigation/Navigation"):
    _DEFS[f"{_action}ActionGoal"] = f"std_msgs/Header header; actionlib_msgs/GoalID goal_id; {_action}Goal goal"
    for _part in ("Result", "Feedback"):
        _DEFS[f"{_action}Action{_part}"] = (f"std_msgs/Header header; actionlib_msgs/GoalStatus status; "
                                            f"{_action}{_part} {_part.lower()}")

# Services: (request definition, response definition).
SERVICE_DEFS: dict[str, tuple[str, str]] = {
    "std_srvs/Empty": ("", ""),
    "std_srvs/Trigger": ("", "bool success; string message"),
    "cyborg_controller/EmotionalStateService": (
        "string nothing",
        "string emotional_state; float32 current_pleasure; float32 current_arousal; float32 current_dominance",
    ),
    "rosapi/Topics": ("", "string[] topics; string[] types"),
    "rosapi/TopicsAndRawTypes": ("", "string[] topics; string[] types; string[] typedefs_full_text"),
    "rosapi/TopicType": ("string topic", "string type"),
    "rosapi/TopicsForType": ("string type", "string[] topics"),
    "rosapi/Services": ("", "string[] services"),
    "rosapi/ServiceType": ("string service", "string type"),
    "rosapi/Nodes": ("", "string[] nodes"),
    "rosapi/GetTime": ("", "time time"),
    "rosapi/GetParam": ("string name; string default", "string value"),
    "rosapi/HasParam": ("string name", "bool exists"),
    "rosapi/GetParamNames": ("", "string[] names"),
    "rosapi/MessageDetails": ("string type", "rosapi/TypeDef[] typedefs"),
    "rosapi/Publishers": ("string topic", "string[] publishers"),
    "rosapi/Subscribers": ("string topic", "string[] subscribers"),
    "rosapi/NodeDetails": ("string node", "string[] subscribing; string[] publishing; string[] services"),
    "rosapi/GetROSVersion": ("", "uint8 version; string distro"),
    "action_msgs/CancelGoal": (
        "action_msgs/GoalInfo goal_info", "int8 return_code; action_msgs/GoalInfo[] goals_canceling",
    ),
}
for _srv, (_req, _resp) in SERVICE_DEFS.items():
    _DEFS[f"{_srv}Request"] = _req
    _DEFS[f"{_srv}Response"] = _resp


def store_name(msg_type: str) -> str:
    """rosbags' name of a type: ``pkg/msg/Type`` (a two-part name gains its ``msg``)."""
    pkg, *_, name = msg_type.split("/")
    return f"{pkg}/msg/{name}"


STORES = {ri.ROS1: get_typestore(Stores.ROS1_NOETIC), ri.ROS2: get_typestore(Stores.ROS2_JAZZY)}
for _store in STORES.values():
    _store.register({n: d for k, v in _DEFS.items() for n, d in get_types_from_msg(v.replace(";", "\n"),
                                                                                   store_name(k)).items()
                     if n not in _store.fielddefs})
# The ROS 2 types the simulator speaks (its log, its actions' status and cancel) are in the schemas of either dialect.
_ROS2_PACKAGES = ("rcl_interfaces/", "action_msgs/", "unique_identifier_msgs/")
STORES[ri.ROS1].register({n: d for n, d in STORES[ri.ROS2].fielddefs.items() if n.startswith(_ROS2_PACKAGES)})
_TIMES = {"builtin_interfaces/msg/Time": "time", "builtin_interfaces/msg/Duration": "duration"}
_PLACEHOLDER = "structure_needs_at_least_one_member"  # rosbags' field of an empty message


def _two_part(name: str) -> str:
    return _TIMES.get(name) or name.replace("/msg/", "/", 1)


def _schema_field(name: str, desc: tuple[Any, Any]) -> tuple[str, str, int | None]:
    kind, detail = desc
    if kind == Nodetype.BASE:
        return name, detail[0], None
    if kind == Nodetype.NAME:
        return name, _two_part(detail), None
    (item_kind, item), length = detail
    return name, item[0] if item_kind == Nodetype.BASE else _two_part(item), length if kind == Nodetype.ARRAY else -1


# two-part name -> [(field, base type, array length: None for a scalar, -1 variable, N fixed)]
SCHEMAS: dict[str, list[tuple[str, str, int | None]]] = {
    _two_part(n): [_schema_field(f, desc) for f, desc in fields if f != _PLACEHOLDER]
    for n, (_, fields) in STORES[ri.ROS1].fielddefs.items() if n not in _TIMES}
_THREE_PART = re.compile(r"/(?:msg|srv|action)/")


def canonical(type_name: str) -> str:
    """The schema's name of a type in either spelling: ``geometry_msgs/msg/Twist`` is ``geometry_msgs/Twist``."""
    if type_name.count("/") != 2:
        return type_name
    two_part = _THREE_PART.sub("/", type_name, count=1)
    return "rosapi/" + two_part[len("rosapi_msgs/"):] if two_part.startswith("rosapi_msgs/") else two_part


_PACKAGES = frozenset(name.split("/", 1)[0] for name in SCHEMAS)


def known_package(msg_type: str) -> bool:
    """Whether the robot has the message package of ``msg_type`` (rosbridge can import its classes)."""
    return msg_type.split("/", 1)[0] in _PACKAGES


INT_RANGES: dict[str, tuple[int, int]] = {
    t: (int(np.iinfo(t).min), int(np.iinfo(t).max))
    for t in ("int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64")
}
INT_RANGES |= {"byte": INT_RANGES["int8"], "char": INT_RANGES["uint8"]}
FLOATS = frozenset({"float32", "float64"})
_EXACT: dict[str, type] = {"bool": bool, "string": str}  # no other Python type passes for these
_ZERO: dict[str, Any] = {**dict.fromkeys(INT_RANGES, 0), **dict.fromkeys(FLOATS, 0.0), "bool": False, "string": ""}
PRIMITIVES = frozenset(_ZERO) | {"time", "duration"}
_BYTE_ARRAYS = frozenset({"uint8", "char"})


_TIME_KEYS = {"sec": "secs", "nanosec": "nsecs"}


class ConversionError(Exception):
    """An incoming message does not fit its type (rosbridge's conversion exceptions)."""


def known(msg_type: str) -> bool:
    return canonical(msg_type) in SCHEMAS


def stamp(t: float | None = None) -> dict[str, int]:
    t = time.time() if t is None else t
    secs = int(t)
    return {"secs": secs, "nsecs": round((t - secs) * 1e9) % 1_000_000_000}


def duration(seconds: float) -> dict[str, int]:
    return stamp(max(0.0, seconds))


def header(frame_id: str = "", t: float | None = None, seq: int = 0) -> dict[str, Any]:
    return {"seq": seq, "stamp": stamp(t), "frame_id": frame_id}


def _default_value(ftype: str, length: int | None) -> Any:
    if length is not None:
        if ftype in _BYTE_ARRAYS:
            return base64.b64encode(bytes(max(length, 0))).decode()
        return [] if length < 0 else [_default_value(ftype, None) for _ in range(length)]
    if ftype in _ZERO:
        return _ZERO[ftype]
    if ftype in ("time", "duration"):
        return {"secs": 0, "nsecs": 0}
    return default(ftype)


def default(msg_type: str) -> dict[str, Any]:
    return {name: _default_value(ftype, length) for name, ftype, length in SCHEMAS[canonical(msg_type)]}


def _mismatch(root: str, expected: str, path: list[str], value: Any) -> ConversionError:
    return ConversionError(
        f"{root} message requires a {expected} for field {'.'.join(path)}, but got a {type(value).__name__}"
    )


def _primitive(root: str, ftype: str, value: Any, path: list[str]) -> Any:
    vt = type(value)
    if ftype in FLOATS:
        if vt is float or vt is int:
            return float(value)
        raise _mismatch(root, ftype, path, value)
    if ftype in INT_RANGES:
        if vt is not int:
            raise _mismatch(root, ftype, path, value)
        lo, hi = INT_RANGES[ftype]
        if not lo <= value <= hi:
            raise ConversionError(f"{root} message field {'.'.join(path)}: {value} out of range for {ftype}")
        return value
    if ftype in _EXACT:
        if vt is not _EXACT[ftype]:
            raise _mismatch(root, ftype, path, value)
        return value
    # time / duration
    if value == "now" and ftype == "time":
        return stamp()
    if vt is not dict:
        raise _mismatch(root, ftype, path, value)
    out = {"secs": 0, "nsecs": 0}
    for key, v in value.items():
        key = _TIME_KEYS.get(key, key)  # ROS 2's spelling, taken by either server
        if key not in out:
            raise ConversionError(f"Message type {ftype} does not have a field {'.'.join([*path, key])}")
        if type(v) is not int:
            raise _mismatch(root, "int", [*path, key], v)
        out[key] = v
    return out


def _field(root: str, ftype: str, length: int | None, value: Any, path: list[str]) -> Any:
    if length is None:
        if ftype in PRIMITIVES:
            return _primitive(root, ftype, value, path)
        if type(value) is not dict:
            raise _mismatch(root, ftype, path, value)
        return _message(root, ftype, value, path)
    if ftype in _BYTE_ARRAYS:
        if type(value) is str:
            try:
                base64.b64decode(value, validate=True)
            except ValueError as exc:
                raise ConversionError(f"{root} field {'.'.join(path)}: invalid base64 ({exc})") from exc
            return value
        if type(value) is list and all(type(v) is int and 0 <= v <= 255 for v in value):
            return base64.b64encode(bytes(value)).decode()
        raise _mismatch(root, f"{ftype}[]", path, value)
    if type(value) is not list:
        raise _mismatch(root, f"{ftype}[]", path, value)
    if length >= 0 and len(value) != length:
        raise ConversionError(
            f"{root} message field {'.'.join(path)} must have {length} elements, got {len(value)}"
        )
    if ftype in INT_RANGES:  # fast path for big int arrays such as OccupancyGrid.data
        lo, hi = INT_RANGES[ftype]
        for v in value:
            if type(v) is not int or not lo <= v <= hi:
                raise _mismatch(root, ftype, path, v)
        return value
    return [_field(root, ftype, None, v, path) for v in value]


def _message(root: str, msg_type: str, value: dict[str, Any], path: list[str]) -> dict[str, Any]:
    schema = SCHEMAS[msg_type]
    names = {name for name, _, _ in schema}
    for key in value:
        if key not in names:
            raise ConversionError(f"Message type {msg_type} does not have a field {'.'.join([*path, key])}")
    out: dict[str, Any] = {}
    for name, ftype, length in schema:
        if name in value:
            out[name] = _field(root, ftype, length, value[name], [*path, name])
            if ftype == "std_msgs/Header" and length is None and "stamp" not in value[name]:
                out[name]["stamp"] = stamp()
        else:
            out[name] = _default_value(ftype, length)
    return out


def normalize(msg_type: str, value: Any) -> dict[str, Any]:
    """Validate ``value`` as a ``msg_type`` message; return it with defaults filled in."""
    msg_type = canonical(msg_type)
    if msg_type not in SCHEMAS:
        raise ConversionError(f"Unable to load the manifest for message type {msg_type}")
    if type(value) is not dict:
        raise ConversionError(f"Expected a dict for a {msg_type} message but got a {type(value).__name__}")
    return _message(msg_type, msg_type, value, [])


def normalize_request(srv_type: str, args: Any) -> dict[str, Any]:
    """Service args as rosbridge takes them: a dict, or a positional list in field order."""
    srv_type = canonical(srv_type)
    schema = SCHEMAS[f"{srv_type}Request"]
    if args is None:
        args = {}
    if type(args) is list:
        if len(args) > len(schema):
            raise ConversionError(f"{srv_type} request takes {len(schema)} args, got {len(args)}")
        args = {name: v for (name, _, _), v in zip(schema, args, strict=False)}
    return normalize(f"{srv_type}Request", args)


def typedefs(msg_type: str) -> list[dict[str, Any]]:
    """rosapi/MessageDetails: the type and every nested type, in the rosapi TypeDef layout."""
    seen: list[str] = []
    todo = [msg_type]  # depth first, each type before the types of its fields
    while todo:
        t = todo.pop(0)
        if t not in seen and t in SCHEMAS:
            seen.append(t)
            todo[:0] = [ftype for _, ftype, _ in SCHEMAS[t] if ftype not in PRIMITIVES]
    return [{
        "type": t,
        "fieldnames": [n for n, _, _ in SCHEMAS[t]],
        "fieldtypes": [f for _, f, _ in SCHEMAS[t]],
        "fieldarraylen": [-1 if ln is None else (0 if ln < 0 else ln) for _, _, ln in SCHEMAS[t]],
        "examples": [json.dumps(_default_value(f, ln)) if f in PRIMITIVES else "{}" for _, f, ln in SCHEMAS[t]],
        "constnames": [],
        "constvalues": [],
    } for t in seen]


def _sanitize(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _sanitize(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_sanitize(v) for v in value]
    return value


def encode(frame: dict[str, Any]) -> str:
    """JSON for the wire; NaN and infinities become null as rosbridge sends them."""
    try:
        return json.dumps(frame, separators=(",", ":"), allow_nan=False)
    except ValueError:
        return json.dumps(_sanitize(frame), separators=(",", ":"), allow_nan=False)


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
        text = encode(frame)
        if not self.ros2:
            return text
        # builtin_interfaces/Time and a Header without seq; a key inside a string value is escaped (\")
        return _SEQ.sub("", text.replace('"secs":', '"sec":').replace('"nsecs":', '"nanosec":'))

    def log(self, level: int, node: str, text: str) -> dict[str, Any]:
        """/rosout's message; ``level`` in ROS 1's scale (1 DEBUG .. 16 FATAL)."""
        if self.ros2:
            return {"stamp": stamp(), "level": 10 * level.bit_length(), "name": node.lstrip("/"),
                    "msg": text, "file": "sim.py", "function": "", "line": 0}
        return {"header": header(), "level": level, "name": node, "msg": text, "file": "sim.py",
                "function": "", "line": 0, "topics": ["/rosout"]}

    def particles(self, header: dict[str, Any], poses: list[dict[str, Any]]) -> dict[str, Any]:
        """amcl's cloud: a PoseArray on ROS 1, nav2_msgs/ParticleCloud on ROS 2."""
        if self.ros2:
            weight = 1.0 / max(1, len(poses))
            return {"header": header, "particles": [{"pose": p, "weight": weight} for p in poses]}
        return {"header": header, "poses": poses}

    def full_text(self, msg_type: str) -> str:
        """The definition with every type it uses after it, as rosapi gives it (empty if unknown)."""
        store, name = STORES[self.ros], store_name(msg_type)
        return store.generate_msgdef(name, ros_version=self.ros)[0] if name in store.fielddefs else ""

    def raw_frame(self, topic: str, msg_type: str, msg: dict[str, Any]) -> bytes:
        """rosbridge's ``cbor-raw`` publish frame: receive time and the serialized message."""
        store, name = STORES[self.ros], store_name(msg_type)
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
    return store.types[name](**{f: _raw_field(store, desc, value.get(f)) for f, desc in store.fielddefs[name][1]})


def _raw_field(store: Any, desc: tuple[Any, Any], value: Any) -> Any:
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
    return [_raw_field(store, item, v) for v in value or ()]


ROS1 = Dialect(ri.ROS1)
ROS2 = Dialect(ri.ROS2)
DIALECTS = {ri.ROS1: ROS1, ri.ROS2: ROS2}
