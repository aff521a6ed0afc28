"""The Cyborg's ROS interface: every topic, service, action and robot string in one place.

Defaults follow ``shared/ROBOT_INTERFACE.md``. Operators re-wire a robot through the
``ROBOT_TOPICS`` / ``ROBOT_SERVICES`` / ``ROBOT_ACTIONS`` settings (mappings of key to
ROS name, filled from the ``ROBOT_NAME_OVERRIDES`` JSON environment variable), so the
rest of the code refers to topics by *key* and never by ROS name.

This module must stay importable without Django configured: the simulator and
benchmarks use it too.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, replace
from enum import StrEnum
from functools import cache
from typing import Any


@dataclass(frozen=True)
class Topic:
    key: str
    name: str
    type: str
    # Browser update rate; the link coalesces faster topics (latest value wins).
    # ``None`` forwards every message (low-rate, event-like topics such as logs).
    ui_rate_hz: float | None = None
    # Subscribed by the robot link at start so the dashboard can show it.
    monitor: bool = False
    latched: bool = False
    # Keep this many recent messages so a page opened later still sees them (logs, events).
    recent: int = 0


@dataclass(frozen=True)
class Service:
    key: str
    name: str
    type: str


@dataclass(frozen=True)
class Action:
    key: str
    name: str  # action server namespace: <name>/goal, /cancel, /status, /feedback, /result
    type: str  # the action type without the Action* suffixes, e.g. move_base_msgs/MoveBase


_T = Topic
_DEFAULT_TOPICS: tuple[Topic, ...] = (
    # monitoring
    _T("battery_soc", "/RosAria/battery_state_of_charge", "std_msgs/Float32", 2, True),
    _T("battery_voltage", "/RosAria/battery_voltage", "std_msgs/Float64", 2, True),
    _T("battery_recharge_state", "/RosAria/battery_recharge_state", "std_msgs/Int8", 2, True),
    _T("motors_state", "/RosAria/motors_state", "std_msgs/Bool", 5, True),
    _T("bumper_state", "/RosAria/bumper_state", "rosaria/BumperState", 5, True),
    _T("sonar", "/RosAria/sonar", "sensor_msgs/PointCloud", 2),
    _T("robot_pose", "/robot_pose", "geometry_msgs/Pose", 10, True),
    _T("amcl_pose", "/amcl_pose", "geometry_msgs/PoseWithCovarianceStamped", 2),
    _T("odom", "/odom", "nav_msgs/Odometry", 10, True),
    _T("map", "/map", "nav_msgs/OccupancyGrid", None, True, latched=True),
    _T("plan", "/move_base/NavfnROS/plan", "nav_msgs/Path", 2, True),
    _T("move_base_status", "/move_base/status", "actionlib_msgs/GoalStatusArray", 2, True),
    _T("navigation_status", "/cyborg_navigation/navigation/status", "actionlib_msgs/GoalStatusArray", 2, True),
    # map overlays: subscribed while a map page shows them (robot/overlays/)
    _T("global_costmap", "/move_base/global_costmap/costmap", "nav_msgs/OccupancyGrid"),
    _T("local_costmap", "/move_base/local_costmap/costmap", "nav_msgs/OccupancyGrid"),
    _T("global_costmap_updates", "/move_base/global_costmap/costmap_updates", "map_msgs/OccupancyGridUpdate"),
    _T("local_costmap_updates", "/move_base/local_costmap/costmap_updates", "map_msgs/OccupancyGridUpdate"),
    _T("particlecloud", "/particlecloud", "geometry_msgs/PoseArray", 5),
    _T("scan", "/RosAria/sim_S3Series_1_laserscan", "sensor_msgs/LaserScan", 15),
    _T("footprint", "/move_base/global_costmap/footprint", "geometry_msgs/PolygonStamped", 5),
    _T("local_plan", "/move_base/TrajectoryPlannerROS/local_plan", "nav_msgs/Path", 10),
    _T("state_change", "/cyborg_controller/state_change", "cyborg_controller/SystemState", None, True, recent=20),
    _T("state_transitions", "/cyborg_controller/state_transitions", "std_msgs/String", None, True),
    _T("emotional_state", "/cyborg_controller/emotional_state", "cyborg_controller/EmotionalState", 4, True),
    _T("emotion_system_status", "/cyborg_controller/emotional_controller_status", "std_msgs/Bool", 4, True),
    _T("robot_mode", "/cyborg_commander/robot_mode", "std_msgs/String", None, True),
    _T("text_to_speech", "/cyborg_audio/text_to_speech", "std_msgs/String", None, True, recent=10),
    _T("tts_feedback", "/cyborg_audio/feedback_text_to_speech", "std_msgs/String", None, True, recent=10),
    _T("playback_feedback", "/cyborg_audio/feedback_playback", "std_msgs/String", None, True),
    # the robot's microphone: subscribed only while someone listens (robot/audio/link.py)
    _T("audio", "/audio/audio", "audio_common_msgs/AudioData"),
    _T("audio_info", "/audio/audio_info", "audio_common_msgs/AudioInfo", None, True, latched=True),
    _T("current_location", "/cyborg_navigation/current_location", "std_msgs/String", None, True),
    # Every container publishes on this topic; keep each one's latest (no coalescing across paths).
    _T("smach_status", "/controller_viewer/smach/container_status", "smach_msgs/SmachContainerStatus", None, True,
       recent=8),
    # Every container re-sends its structure periodically; the link keeps each path's (robot/introspection).
    _T("smach_structure", "/controller_viewer/smach/container_structure", "smach_msgs/SmachContainerStructure", 1,
       True),
    # Components may report in separate arrays; the link keeps each one's latest (robot/introspection).
    _T("diagnostics", "/diagnostics", "diagnostic_msgs/DiagnosticArray", 1, True),
    _T("rosout", "/rosout", "rosgraph_msgs/Log", None, True, recent=200),
    _T("tf", "/tf", "tf2_msgs/TFMessage", 5),
    _T("tf_static", "/tf_static", "tf2_msgs/TFMessage", None, latched=True),
    _T("client_count", "/client_count", "std_msgs/Int32", None, latched=True),
    # commands (the robot subscribes to these)
    _T("register_event", "/cyborg_controller/register_event", "std_msgs/String"),
    _T("emotional_controller", "/cyborg_controller/emotional_controller", "std_msgs/String"),
    _T("set_emotional_state", "/cyborg_controller/set_emotional_state", "std_msgs/String"),
    _T("emotional_feedback", "/cyborg_controller/emotional_feedback", "cyborg_controller/EmotionalFeedback"),
    _T("playback", "/cyborg_audio/playback", "std_msgs/String"),
    _T("domecontrol", "/cyborg_visual/domecontrol", "std_msgs/String"),
    _T("cmd_vel", "/cmd_vel", "geometry_msgs/Twist"),
    # operator audio for the robot's speakers; its format is declared latched on speaker_info
    _T("speaker", "/cyborg_audio/speaker", "audio_common_msgs/AudioData"),
    _T("speaker_info", "/cyborg_audio/speaker_info", "audio_common_msgs/AudioInfo", latched=True),
    _T("move_base_simple_goal", "/move_base_simple/goal", "geometry_msgs/PoseStamped"),
    _T("initialpose", "/initialpose", "geometry_msgs/PoseWithCovarianceStamped"),
)

_DEFAULT_SERVICES: tuple[Service, ...] = (
    Service("enable_motors", "/RosAria/enable_motors", "std_srvs/Empty"),
    Service("disable_motors", "/RosAria/disable_motors", "std_srvs/Empty"),
    Service("get_emotional_state", "/get_emotional_state", "cyborg_controller/EmotionalStateService"),
    Service("rosapi_topics", "/rosapi/topics", "rosapi/Topics"),
    Service("rosapi_topic_type", "/rosapi/topic_type", "rosapi/TopicType"),
    Service("rosapi_services", "/rosapi/services", "rosapi/Services"),
    Service("rosapi_nodes", "/rosapi/nodes", "rosapi/Nodes"),
    Service("rosapi_get_time", "/rosapi/get_time", "rosapi/GetTime"),
    Service("rosapi_publishers", "/rosapi/publishers", "rosapi/Publishers"),
    Service("rosapi_subscribers", "/rosapi/subscribers", "rosapi/Subscribers"),
    Service("rosapi_node_details", "/rosapi/node_details", "rosapi/NodeDetails"),
)

_DEFAULT_ACTIONS: tuple[Action, ...] = (
    Action("move_base", "/move_base", "move_base_msgs/MoveBase"),
    Action("navigation", "/cyborg_navigation/navigation", "cyborg_navigation/Navigation"),
)


# --- ROS 2 (Jazzy, Nav2) ------------------------------------------------------------------
# The same keys on a ROS 2 robot (ROBOT_INTERFACE.md, "ROS 2 robots"): every type spelled in three
# parts, and these names and types where Nav2 and rcl differ from the ROS 1 robot by more than that.
ROS1, ROS2 = 1, 2
ROS_VERSIONS = (ROS1, ROS2)
_ROS2_TOPICS: dict[str, tuple[str, str]] = {
    "plan": ("/plan", "nav_msgs/msg/Path"),
    "move_base_status": ("/navigate_to_pose/_action/status", "action_msgs/msg/GoalStatusArray"),
    "navigation_status": ("/cyborg_navigation/navigation/_action/status", "action_msgs/msg/GoalStatusArray"),
    "global_costmap": ("/global_costmap/costmap", "nav_msgs/msg/OccupancyGrid"),
    "local_costmap": ("/local_costmap/costmap", "nav_msgs/msg/OccupancyGrid"),
    "global_costmap_updates": ("/global_costmap/costmap_updates", "map_msgs/msg/OccupancyGridUpdate"),
    "local_costmap_updates": ("/local_costmap/costmap_updates", "map_msgs/msg/OccupancyGridUpdate"),
    "particlecloud": ("/particle_cloud", "nav2_msgs/msg/ParticleCloud"),
    "footprint": ("/global_costmap/published_footprint", "geometry_msgs/msg/PolygonStamped"),
    "local_plan": ("/local_plan", "nav_msgs/msg/Path"),
    "rosout": ("/rosout", "rcl_interfaces/msg/Log"),
    "move_base_simple_goal": ("/goal_pose", "geometry_msgs/msg/PoseStamped"),
}
_ROS2_ACTIONS: dict[str, tuple[str, str]] = {
    "move_base": ("/navigate_to_pose", "nav2_msgs/action/NavigateToPose"),
}
# Where a ROS 2 action server's goal status and cancel-everything service live.
ACTION_STATUS_SUFFIX = "/_action/status"
ACTION_CANCEL_SUFFIX = "/_action/cancel_goal"
ACTION_STATUS_TYPE = "action_msgs/msg/GoalStatusArray"
ACTION_CANCEL_TYPE = "action_msgs/srv/CancelGoal"


def ros2_spelling(type_name: str, kind: str = "msg") -> str:
    """``pkg/Type`` as ROS 2 spells it (``pkg/msg/Type``); a three-part name is kept."""
    package, _, name = type_name.partition("/")
    if "/" in name or not name:
        return type_name
    if kind == "srv" and package == "rosapi":
        package = "rosapi_msgs"
    return f"{package}/{kind}/{name}"


def ros1_spelling(type_name: str) -> str:
    """``pkg/msg/Type`` (or ``srv``, ``action``) as ROS 1 spells it: ``pkg/Type``."""
    parts = type_name.split("/")
    return f"{parts[0]}/{parts[2]}" if len(parts) == 3 and parts[1] in ("msg", "srv", "action") else type_name


def _ros2_defaults[Named: (Topic, Service, Action)](defaults: tuple[Named, ...], kind: str,
                                                     table: dict[str, tuple[str, str]]) -> tuple[Named, ...]:
    out = []
    for d in defaults:
        name, type_name = table.get(d.key, (d.name, ros2_spelling(d.type, kind)))
        out.append(replace(d, name=name, type=type_name))
    return tuple(out)


def _defaults(ros: int) -> tuple[tuple[Topic, ...], tuple[Service, ...], tuple[Action, ...]]:
    if ros == ROS2:
        return (_ros2_defaults(_DEFAULT_TOPICS, "msg", _ROS2_TOPICS),
                _ros2_defaults(_DEFAULT_SERVICES, "srv", {}),
                _ros2_defaults(_DEFAULT_ACTIONS, "action", _ROS2_ACTIONS))
    return _DEFAULT_TOPICS, _DEFAULT_SERVICES, _DEFAULT_ACTIONS


_active_ros: int | None = None


def use_ros(version: int | None) -> None:
    """Make ``version`` the ROS whose names this process uses (the link, once it has found out which
    ROS the robot runs; None: back to the ``ROBOT_ROS`` setting)."""
    global _active_ros
    if version is not None and version not in ROS_VERSIONS:
        raise ValueError(f"ROS version is 1 or 2, not {version!r}")
    _active_ros = version


def configured_ros() -> int | None:
    """The ROS version the ``ROBOT_ROS`` setting forces (1 or 2), or None to find out from the robot."""
    value = str(_setting("ROBOT_ROS", "") or "auto").strip().lower()
    if value in ("", "auto"):
        return None
    if value not in ("1", "2"):
        raise ValueError(f"ROBOT_ROS is 1, 2 or auto, not {value!r}")
    return int(value)


def ros_version() -> int:
    """The ROS whose names and types this process uses: found out, else forced, else ROS 1."""
    return _active_ros or configured_ros() or ROS1


def _setting(name: str, default: object) -> object:
    try:
        from django.conf import settings

        return getattr(settings, name, default)
    except Exception:  # Django not configured: plain defaults (simulator scripts, benches)
        return default


def _overrides(setting: str) -> dict[str, str]:
    return dict(_setting(setting, {}) or {})  # type: ignore[call-overload]


def _apply[Named: (Topic, Service, Action)](defaults: tuple[Named, ...], setting: str) -> dict[str, Named]:
    names = _overrides(setting)
    unknown = set(names) - {d.key for d in defaults}
    if unknown:
        raise KeyError(f"{setting} names unknown keys: {', '.join(sorted(unknown))}")
    return {d.key: replace(d, name=names.get(d.key, d.name)) for d in defaults}


@cache
def _topics(ros: int) -> dict[str, Topic]:
    return _apply(_defaults(ros)[0], "ROBOT_TOPICS")


@cache
def _services(ros: int) -> dict[str, Service]:
    return _apply(_defaults(ros)[1], "ROBOT_SERVICES")


@cache
def _actions(ros: int) -> dict[str, Action]:
    return _apply(_defaults(ros)[2], "ROBOT_ACTIONS")


def reload() -> None:
    """Forget cached names (tests that override the settings call this)."""
    for f in (_topics, _services, _actions, _latch_rules, _latched):
        f.cache_clear()
    use_ros(None)


def topic(key: str, ros: int | None = None) -> Topic:
    return _topics(ros or ros_version())[key]


def topics(ros: int | None = None) -> tuple[Topic, ...]:
    return tuple(_topics(ros or ros_version()).values())


def latched_names() -> frozenset[str]:
    """The topics the robot publishes latched (a later subscriber gets the last message at once)."""
    return _latched(ros_version())


@cache
def _latched(ros: int) -> frozenset[str]:
    return frozenset(t.name for t in _topics(ros).values() if t.latched)


def monitored_topics() -> tuple[Topic, ...]:
    return tuple(t for t in topics() if t.monitor)


def topic_by_name(name: str) -> Topic | None:
    return next((t for t in topics() if t.name == name), None)


# A global graph name: "/" then tokens of a letter followed by letters, digits and "_"; ROS 2's hidden
# tokens start with "_" (/navigate_to_pose/_action/status): readable, never written by the product.
_TOPIC_NAME = re.compile(r"(/_?[A-Za-z][A-Za-z0-9_]*)+")


def is_hidden(name: str) -> bool:
    """A ROS 2 hidden name (an action's status, feedback or services): watched, never published to."""
    return "/_" in name
TOPIC_NAME_MAX = 255


def topic_name_problem(name: object) -> str | None:
    """Why ``name`` is not a global ROS topic name, or None when it is one."""
    if not isinstance(name, str) or not name:
        return "a topic name is a non-empty text"
    if len(name) > TOPIC_NAME_MAX:
        return f"a topic name has at most {TOPIC_NAME_MAX} characters"
    if not _TOPIC_NAME.fullmatch(name):
        return (f"{name[:80]!r} is not a ROS topic name (like /robot_pose: a leading /, then words of "
                "letters, digits and _ that start with a letter, or with _ and a letter on ROS 2)")
    return None


def service(key: str, ros: int | None = None) -> Service:
    return _services(ros or ros_version())[key]


def services(ros: int | None = None) -> tuple[Service, ...]:
    return tuple(_services(ros or ros_version()).values())


def action(key: str, ros: int | None = None) -> Action:
    return _actions(ros or ros_version())[key]


def actions(ros: int | None = None) -> tuple[Action, ...]:
    return tuple(_actions(ros or ros_version()).values())


# --- Robot strings -------------------------------------------------------------------


class Mode(StrEnum):
    """Operating modes; the value is the string the robot's commander expects."""

    BEHAVIOUR = "behaviour"
    DEMO = "demo"
    MANUAL = "manual control"
    STOP = "stop"

    @property
    def short(self) -> str:
        """The API/UI name (``manual`` rather than ``manual control``)."""
        return self.value.split()[0]

    @classmethod
    def from_short(cls, name: str) -> Mode:
        for mode in cls:
            if name in (mode.short, mode.value):
                return mode
        raise ValueError(name)


class Event(StrEnum):
    ABORTED = "aborted"
    SUCCEEDED = "succeeded"
    PREEMPTED = "preempted"
    BEHAVIOUR_START = "behaviour_start"
    DEMO_START = "demo_start"
    MANUAL_START = "manual_start"
    SUSPEND = "suspend"
    RESTART = "restart"


class State(StrEnum):
    STARTUP = "startup"
    SUSPENSION = "suspension"
    DEMO = "demo"
    MANUAL = "manual"
    BEHAVIOUR = "behaviour"
    IDLE = "idle"


EMOTION_SYSTEM_ON = "ON"
EMOTION_SYSTEM_OFF = "OFF"
MAP_FRAME = "map"

# Commander sequences (ROBOT_INTERFACE.md, "Modes of operation"): each step is
# ("event", name) | ("emotion_system", bool) | ("pause", seconds).
COMMANDER_PAUSE_S = 0.5
Step = tuple[str, str | bool | float]
COMMANDER_SEQUENCES: dict[Mode, tuple[Step, ...]] = {
    Mode.BEHAVIOUR: (
        ("event", Event.ABORTED), ("pause", COMMANDER_PAUSE_S),
        ("emotion_system", True), ("event", Event.BEHAVIOUR_START),
    ),
    Mode.DEMO: (
        ("event", Event.ABORTED), ("pause", COMMANDER_PAUSE_S),
        ("emotion_system", False), ("event", Event.DEMO_START),
    ),
    Mode.MANUAL: (
        ("event", Event.ABORTED), ("pause", COMMANDER_PAUSE_S),
        ("emotion_system", False), ("event", Event.MANUAL_START),
    ),
    Mode.STOP: (
        ("emotion_system", False), ("event", Event.ABORTED),
        ("pause", COMMANDER_PAUSE_S), ("event", Event.SUSPEND),
    ),
}
# What a mode request does once the state machine is in suspension: the emotion system switch
# and the event that enters the mode (none for stop: suspension is the target).
MODE_ENTRY: dict[Mode, tuple[bool, Event | None]] = {
    Mode.BEHAVIOUR: (True, Event.BEHAVIOUR_START),
    Mode.DEMO: (False, Event.DEMO_START),
    Mode.MANUAL: (False, Event.MANUAL_START),
    Mode.STOP: (False, None),
}
# Top-level states outside the behaviour container; every other state is one of its leaves.
TOP_LEVEL_STATES: frozenset[str] = frozenset({State.STARTUP, State.SUSPENSION, State.DEMO, State.MANUAL})
# Inside the container every state returns to idle on `aborted`, except sleeping (`preempted`);
# idle leaves the container with `suspend` (ROBOT_INTERFACE.md, "The state machine").
SLEEPING_STATE = "sleeping"
# Leaf states inside the behaviour container (incl. the navigation container's leaves).
# state_change names the leaf entered, so "behaviour_start" reports to_system_state "idle":
# any of these means the robot is in behaviour mode.
BEHAVIOUR_STATES: frozenset[str] = frozenset({
    "idle", "show_off_mea", "conveying_emotional_state", "music_horror", "astrolanguage", "waking_up",
    "sleepy", "exhausted", "sleeping", "navigation_planning", "navigation_go_to_emotional",
    "navigation_go_to_schedular", "wandering_emotional",
})
# The state each mode should reach, for the requested-vs-reached check.
MODE_TARGET_STATE: dict[Mode, State] = {
    Mode.BEHAVIOUR: State.BEHAVIOUR,
    Mode.DEMO: State.DEMO,
    Mode.MANUAL: State.MANUAL,
    Mode.STOP: State.SUSPENSION,
}

# Emotion presets (PAD, each in -1..1); the admin's EmotionPreset table is seeded from these.
EMOTION_PRESETS: dict[str, tuple[float, float, float]] = {
    "angry": (-0.51, 0.59, 0.25),
    "bored": (-0.65, -0.62, -0.33),
    "curious": (0.22, 0.62, -0.10),
    "dignified": (0.55, 0.22, 0.61),
    "elated": (0.50, 0.42, 0.23),
    "inhibited": (-0.54, -0.04, -0.41),
    "puzzled": (-0.41, 0.48, -0.33),
    "loved": (0.89, 0.54, -0.18),
    "unconcerned": (-0.13, -0.41, 0.08),
    "hungry": (-0.44, 0.14, -0.21),
    "sleepy": (0.20, -0.70, -0.44),
}

# The speaker's format (ROBOT_INTERFACE.md: raw PCM S16LE, 16 kHz, mono, chunks of 20-100 ms).
SPEAKER_RATE_HZ = 16000
SPEAKER_CHANNELS = 1
SPEAKER_SAMPLE_FORMAT = "S16LE"
SPEAKER_CODING = "wave"
SPEAKER_CHUNK_MS = (20, 100)


# Sound (the microphone, the speaker): heard only through the audio socket, by operators, audited;
# never echoed on the topics page or watched as a key, whatever topic carries it.
SOUND_TYPES: frozenset[str] = frozenset({"audio_common_msgs/AudioData", "audio_common_msgs/msg/AudioData"})


def speaker_info() -> dict[str, object]:
    """The AudioInfo message declaring what goes out on the speaker topic."""
    return {"channels": SPEAKER_CHANNELS, "sample_rate": SPEAKER_RATE_HZ, "sample_format": SPEAKER_SAMPLE_FORMAT,
            "bitrate": SPEAKER_RATE_HZ * 16 * SPEAKER_CHANNELS, "coding_format": SPEAKER_CODING}


NAVIGATION_ORDERS = ("navigation_go_to", "navigation_wander", "navigation_dock")

LOG_LEVELS: dict[int, str] = {1: "DEBUG", 2: "INFO", 4: "WARN", 8: "ERROR", 16: "FATAL"}

# diagnostic_msgs/DiagnosticStatus levels.
DIAGNOSTIC_OK, DIAGNOSTIC_WARN, DIAGNOSTIC_ERROR, DIAGNOSTIC_STALE = 0, 1, 2, 3
DIAGNOSTIC_LEVELS: dict[int, str] = {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}

RECHARGE_STATES: dict[int, str] = {
    -1: "unknown", 0: "not charging", 1: "bulk", 2: "overcharge", 3: "float", 4: "balance",
}

GOAL_STATUS: dict[int, str] = {
    0: "pending", 1: "active", 2: "preempted", 3: "succeeded", 4: "aborted",
    5: "rejected", 6: "preempting", 7: "recalling", 8: "recalled", 9: "lost",
}


_ACTION_TOPIC_TYPES: dict[str, str] = {
    "goal": "{type}ActionGoal", "cancel": "actionlib_msgs/GoalID", "status": "actionlib_msgs/GoalStatusArray",
    "feedback": "{type}ActionFeedback", "result": "{type}ActionResult",
}


def action_topic(key: str, suffix: str, ros: int | None = None) -> tuple[str, str]:
    """(name, type) of one of an action server's topics: suffix goal|cancel|status|feedback|result.
    On ROS 2 the status is the action's hidden status topic; goal and cancel are the link's to route."""
    a = action(key, ros)
    if suffix == "status" and (ros or ros_version()) == ROS2:
        return a.name + ACTION_STATUS_SUFFIX, ACTION_STATUS_TYPE
    return f"{a.name}/{suffix}", _ACTION_TOPIC_TYPES[suffix].format(type=a.type)


# --- what still reaches the robot while the E-STOP is latched ------------------------------
# Everything that moves the robot or changes its mode or motors is held back until an operator
# releases the stop. What the stop itself sends passes: a zero Twist (from anyone), and from the
# stop's own steps only, the walk to suspension (the events out of the behaviour container and out
# of a mode), the emotion system OFF and the mode "stop". Cancelling goals and motors off pass: a
# topic or service not named here cannot move the robot.
STOPPING_EVENTS: frozenset[str] = frozenset({Event.ABORTED, Event.PREEMPTED, Event.SUSPEND})


ZERO_TWIST = {"linear": {"x": 0.0, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}


def is_zero_twist(msg: dict[str, Any]) -> bool:
    parts = (msg.get("linear") or {}, msg.get("angular") or {})
    return all(float(part.get(axis) or 0.0) == 0.0 for part in parts for axis in ("x", "y", "z"))


def _never(msg: dict[str, Any]) -> bool:
    return False


def _data_in(allowed: frozenset[str]) -> Callable[[dict[str, Any]], bool]:
    return lambda msg: msg.get("data") in allowed


LatchRule = Callable[[dict[str, Any]], bool]  # the message (or a service's arguments) may pass
_LATCH_TOPICS: dict[str, LatchRule] = {
    "cmd_vel": is_zero_twist,
    "register_event": _data_in(STOPPING_EVENTS),
    "robot_mode": _data_in(frozenset({Mode.STOP.value})),
    "emotional_controller": _data_in(frozenset({EMOTION_SYSTEM_OFF})),
    "move_base_simple_goal": _never,
    "initialpose": _never,
}
_LATCH_ACTION_GOALS = ("move_base", "navigation")
_LATCH_SERVICES: dict[str, LatchRule] = {"enable_motors": _never}


@cache
def _latch_rules(ros: int) -> dict[str, LatchRule]:
    rules = {topic(key, ros).name: rule for key, rule in _LATCH_TOPICS.items()}
    # A goal is a publish on <action>/goal (the link sends it as a ROS 2 action goal on ROS 2).
    rules.update({action_topic(key, "goal", ros)[0]: _never for key in _LATCH_ACTION_GOALS})
    rules.update({service(key, ros).name: rule for key, rule in _LATCH_SERVICES.items()})
    return rules


def passes_latch(name: str, msg: dict[str, Any], *, by_the_stop: bool) -> bool:
    """May this publish on topic ``name`` (or call of service ``name``) reach the robot while the
    E-STOP is latched? ``by_the_stop``: it is one of the stop's own steps."""
    if name == topic("cmd_vel").name:
        return is_zero_twist(msg)
    rule = _latch_rules(ros_version()).get(name)
    return rule is None or (by_the_stop and rule(msg))
