"""ROS 1 message schemas and rosbridge-style JSON conversion.

Only the types the Cyborg uses are known. Incoming messages are validated and
normalised the way rosbridge_library's ``message_conversion`` does it (ROS 1 branch):
unknown keys and float-for-int values are rejected, ints are fine for floats, missing
fields take defaults, a ``header`` object without a stamp is stamped now, byte arrays
travel as base64.
"""

from __future__ import annotations

import base64
import json
import math
import re
import time
from typing import Any

import numpy as np

# Message definitions in the .msg syntax ("type name" pairs separated by ';').
_DEFS: dict[str, str] = {
    "std_msgs/Header": "uint32 seq; time stamp; string frame_id",
    "std_msgs/Empty": "",
    "audio_common_msgs/AudioData": "uint8[] data",
    "audio_common_msgs/AudioInfo": (
        "uint8 channels; uint32 sample_rate; string sample_format; uint32 bitrate; string coding_format"
    ),
    "geometry_msgs/Vector3": "float64 x; float64 y; float64 z",
    "geometry_msgs/Point": "float64 x; float64 y; float64 z",
    "geometry_msgs/Point32": "float32 x; float32 y; float32 z",
    "geometry_msgs/PointStamped": "std_msgs/Header header; geometry_msgs/Point point",
    "geometry_msgs/Quaternion": "float64 x; float64 y; float64 z; float64 w",
    "geometry_msgs/Pose": "geometry_msgs/Point position; geometry_msgs/Quaternion orientation",
    "geometry_msgs/Pose2D": "float64 x; float64 y; float64 theta",
    "geometry_msgs/PoseStamped": "std_msgs/Header header; geometry_msgs/Pose pose",
    "geometry_msgs/PoseWithCovariance": "geometry_msgs/Pose pose; float64[36] covariance",
    "geometry_msgs/PoseWithCovarianceStamped": "std_msgs/Header header; geometry_msgs/PoseWithCovariance pose",
    "geometry_msgs/PoseArray": "std_msgs/Header header; geometry_msgs/Pose[] poses",
    "geometry_msgs/Polygon": "geometry_msgs/Point32[] points",
    "geometry_msgs/PolygonStamped": "std_msgs/Header header; geometry_msgs/Polygon polygon",
    "geometry_msgs/Twist": "geometry_msgs/Vector3 linear; geometry_msgs/Vector3 angular",
    "geometry_msgs/TwistStamped": "std_msgs/Header header; geometry_msgs/Twist twist",
    "geometry_msgs/TwistWithCovariance": "geometry_msgs/Twist twist; float64[36] covariance",
    "geometry_msgs/Transform": "geometry_msgs/Vector3 translation; geometry_msgs/Quaternion rotation",
    "geometry_msgs/TransformStamped": (
        "std_msgs/Header header; string child_frame_id; geometry_msgs/Transform transform"
    ),
    "nav_msgs/MapMetaData": (
        "time map_load_time; float32 resolution; uint32 width; uint32 height; geometry_msgs/Pose origin"
    ),
    "nav_msgs/OccupancyGrid": "std_msgs/Header header; nav_msgs/MapMetaData info; int8[] data",
    "map_msgs/OccupancyGridUpdate": (
        "std_msgs/Header header; int32 x; int32 y; uint32 width; uint32 height; int8[] data"
    ),
    "nav_msgs/Path": "std_msgs/Header header; geometry_msgs/PoseStamped[] poses",
    "nav_msgs/Odometry": (
        "std_msgs/Header header; string child_frame_id; geometry_msgs/PoseWithCovariance pose; "
        "geometry_msgs/TwistWithCovariance twist"
    ),
    "actionlib_msgs/GoalID": "time stamp; string id",
    "actionlib_msgs/GoalStatus": "actionlib_msgs/GoalID goal_id; uint8 status; string text",
    "actionlib_msgs/GoalStatusArray": "std_msgs/Header header; actionlib_msgs/GoalStatus[] status_list",
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
    "rosgraph_msgs/Log": (
        "std_msgs/Header header; int8 level; string name; string msg; string file; string function; "
        "uint32 line; string[] topics"
    ),
    "tf2_msgs/TFMessage": "geometry_msgs/TransformStamped[] transforms",
    "sensor_msgs/ChannelFloat32": "string name; float32[] values",
    "sensor_msgs/PointCloud": (
        "std_msgs/Header header; geometry_msgs/Point32[] points; sensor_msgs/ChannelFloat32[] channels"
    ),
    "sensor_msgs/LaserScan": (
        "std_msgs/Header header; float32 angle_min; float32 angle_max; float32 angle_increment; "
        "float32 time_increment; float32 scan_time; float32 range_min; float32 range_max; float32[] ranges; "
        "float32[] intensities"
    ),
    "sensor_msgs/CompressedImage": "std_msgs/Header header; string format; uint8[] data",
    "rosaria/BumperState": "std_msgs/Header header; bool[] front_bumpers; bool[] rear_bumpers",
    "diagnostic_msgs/KeyValue": "string key; string value",
    "diagnostic_msgs/DiagnosticStatus": (
        "byte level; string name; string message; string hardware_id; diagnostic_msgs/KeyValue[] values"
    ),
    "diagnostic_msgs/DiagnosticArray": "std_msgs/Header header; diagnostic_msgs/DiagnosticStatus[] status",
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
    # ROS 2 (schemas keyed by the two-part name; ``canonical`` maps pkg/msg/Type to it)
    "rcl_interfaces/Log": (
        "time stamp; uint8 level; string name; string msg; string file; string function; uint32 line"
    ),
    "nav2_msgs/Particle": "geometry_msgs/Pose pose; float64 weight",
    "nav2_msgs/ParticleCloud": "std_msgs/Header header; nav2_msgs/Particle[] particles",
    "nav2_msgs/NavigateToPoseGoal": "geometry_msgs/PoseStamped pose; string behavior_tree",
    "nav2_msgs/NavigateToPoseResult": "uint16 error_code; string error_msg",
    "nav2_msgs/NavigateToPoseFeedback": (
        "geometry_msgs/PoseStamped current_pose; duration navigation_time; duration estimated_time_remaining; "
        "int16 number_of_recoveries; float32 distance_remaining"
    ),
    "unique_identifier_msgs/UUID": "uint8[16] uuid",
    "action_msgs/GoalInfo": "unique_identifier_msgs/UUID goal_id; time stamp",
    "action_msgs/GoalStatus": "action_msgs/GoalInfo goal_info; int8 status",
    "action_msgs/GoalStatusArray": "action_msgs/GoalStatus[] status_list",
    "rosapi/TypeDef": (
        "string type; string[] fieldnames; string[] fieldtypes; int32[] fieldarraylen; string[] examples; "
        "string[] constnames; string[] constvalues"
    ),
}

# std_msgs' wrappers of one primitive: std_msgs/UInt8 is "uint8 data".
for _name in ("String", "Bool", "Float32", "Float64", "Int8", "UInt8", "Int16", "Int32", "Int64", "UInt32", "Time"):
    _DEFS[f"std_msgs/{_name}"] = f"{_name.lower()} data"

# actionlib wrappers, generated the way genaction does.
for _action in ("move_base_msgs/MoveBase", "cyborg_navigation/Navigation"):
    _DEFS[f"{_action}ActionGoal"] = f"std_msgs/Header header; actionlib_msgs/GoalID goal_id; {_action}Goal goal"
    _DEFS[f"{_action}ActionResult"] = (
        f"std_msgs/Header header; actionlib_msgs/GoalStatus status; {_action}Result result"
    )
    _DEFS[f"{_action}ActionFeedback"] = (
        f"std_msgs/Header header; actionlib_msgs/GoalStatus status; {_action}Feedback feedback"
    )

# Services: (request definition, response definition).
_THREE_PART = re.compile(r"/(?:msg|srv|action)/")


def canonical(type_name: str) -> str:
    """The schema's name of a type in either spelling: ``geometry_msgs/msg/Twist`` is ``geometry_msgs/Twist``."""
    if type_name.count("/") != 2:
        return type_name
    two_part = _THREE_PART.sub("/", type_name, count=1)
    return "rosapi/" + two_part[len("rosapi_msgs/"):] if two_part.startswith("rosapi_msgs/") else two_part


def known_package(msg_type: str) -> bool:
    """Whether the robot has the message package of ``msg_type`` (rosbridge can import its classes)."""
    return any(name.split("/", 1)[0] == msg_type.split("/", 1)[0] for name in _DEFS)


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


def _parse(definition: str) -> list[tuple[str, str, int | None]]:
    """[(name, base type, array length)] where length is None (scalar), -1 (variable) or N."""
    return [(m["name"], m["type"], None if m["size"] is None else int(m["size"] or -1))
            for m in re.finditer(r"(?P<type>[\w/]+)(?:\[(?P<size>\d*)\])?\s+(?P<name>\w+)", definition)]


SCHEMAS: dict[str, list[tuple[str, str, int | None]]] = {k: _parse(v) for k, v in _DEFS.items()}


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
