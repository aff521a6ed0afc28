"""Channel-layer names and payload shapes, defined once.

Group names may only use letters, digits, ``-``, ``_`` and ``.``.
"""

from __future__ import annotations

from typing import Any, Literal, TypedDict

# Every drive page hears who holds the driving lock.
LOCK_GROUP = "teleop.lock"
# Listening pages hear the robot's microphone; audio pages hear who holds the talk lock.
MIC_GROUP = "audio.mic"
TALK_GROUP = "audio.talk"
# Every front-door socket hears when what tools may do changed (dashboard.revocation).
FRONTDOOR_GROUP = "frontdoor"


def person_group(user_id: object) -> str:
    """Every drive and audio socket of one person (their access changed: dashboard.revocation)."""
    return f"person.{user_id}"

# Latest-state keys the server writes itself (no ROS topic behind them).
STATUS_KEY = "_link"  # the link's connection status
MODE_REQUEST_KEY = "mode_request"  # the last requested mode
MAP_META_KEY = "map_meta"  # the map's metadata (the grid itself never goes into the store)
GOAL_KEY = "nav_goal"  # the goal this server sent last
GOAL_STATUS_KEY = "nav_goal_status"  # what the robot reported for recent goals
LOCATIONS_KEY = "nav_locations"  # sent on change only, never stored
AT_LOCATION_KEY = "at_location"  # the named location the robot is at, by its word or its pose
SMACH_GRAPH_KEY = "smach_graph"  # the state machine's containers as a graph (robot.introspection)
SMACH_ACTIVE_KEY = "smach_active"  # its active states, and the events that leave them
DIAGNOSTICS_KEY = "diagnostics_summary"  # the latest diagnostics of every component
ALERTS_KEY = "alerts"  # the alerts on now (written by robot.alerts.engine where the link runs)
LATCH_KEY = "estop"  # the E-STOP latch (written by robot.estop.latch, read by the link)
# Map overlays, made by the link from the robot's topics (robot.overlays): map-frame shapes, costmap tiles.
OVERLAY_SCAN_KEY = "overlay_scan"
OVERLAY_PARTICLES_KEY = "overlay_particles"
OVERLAY_FOOTPRINT_KEY = "overlay_footprint"
OVERLAY_LOCAL_PLAN_KEY = "overlay_local_plan"
OVERLAY_GLOBAL_COSTMAP_KEY = "overlay_global_costmap"
OVERLAY_LOCAL_COSTMAP_KEY = "overlay_local_costmap"
OVERLAY_SONAR_KEY = "overlay_sonar"


class SharedMessage(dict):
    """A message every receiver of a group send may read but never changes.

    The in-memory channel layer deep-copies a message for each channel; for a stream every
    listener hears (the robot's microphone) those copies would cost the most. Other layers
    serialise it as a dict.
    """

    def __deepcopy__(self, memo: dict[int, Any]) -> SharedMessage:
        return self


class TopicUpdate(TypedDict):
    type: Literal["robot.update"]
    key: str
    topic: str
    msg_type: str
    msg: dict[str, Any]
    t: float  # epoch seconds when the link received it


class LinkStatus(TypedDict):
    type: Literal["robot.status"]
    connected: bool
    url: str
    since: float  # epoch seconds of the last change
    attempts: int  # connection attempts since the last drop
    link_alive: float  # epoch seconds of the link's last heartbeat
    command_path: bool  # the link answered its last ping over the request channel
    failing_tasks: list[str]  # the link process's supervised tasks waiting to restart
    holder: str | None  # scaled mode: the link process holding the lease
    failed_subscriptions: dict[str, str]  # topic -> why the robot refused it (since the last connect)
    connecting_until: float  # epoch seconds: a link just started, not yet connected, is connecting until then
    responding: bool  # the robot said something (a message, a rosapi answer) within ROBOT_HANG_S
    heard_at: float  # epoch seconds when it last did
    ros: int  # the ROS the robot runs (1 or 2), as the link found out or ROBOT_ROS forces


class LinkRequest(TypedDict, total=False):
    type: Literal["link.request"]
    request_id: str
    reply_to: str
    deadline: float  # epoch seconds; the link drops requests it gets too late
    op: str  # publish | call_service | reconnect | topics_watch | ...
    key: str
    topic: str
    msg_type: str
    msg: dict[str, Any]
    service: str
    service_type: str
    args: dict[str, Any]
    timeout: float
    stopping: bool  # stops the robot or does not move it: may pass the latch (interface.passes_latch)
    emergency: bool  # one of the E-STOP's own steps: the direct path, and a link that cannot prove its lease
    fresh_press: bool  # cmd_vel: a driver's first move after letting go (passes the guard's lost-link hold)
    by: str  # estop: who pressed it
    at: float  # estop: when (epoch seconds)
    listener: str  # audio: which listener's lease
    on: bool
    holder: str  # topics_watch: which web process's leases
    topics: list[str]  # topics_watch: every topic that holder's pages watch
    held: list[str]  # topics_watch: the registry topics (keys) that holder's pages' live keys need
    window_s: float  # topics_rate: how long to count messages


class LinkReply(TypedDict, total=False):
    type: Literal["link.reply"]
    request_id: str
    ok: bool
    error: str
    error_code: str  # offline | timeout | failed | invalid
    values: Any
    standby: bool  # answered by a standby link, which only stops the robot (robot.link.standby)
    listeners: int  # audio: how many listeners hold a lease
    refused: dict[str, dict[str, str]]  # topics_watch: topic -> {code, error} for the ones not watched
