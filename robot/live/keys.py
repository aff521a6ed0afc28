"""Which latest-state keys each page (and the state API) watches, and which a page may watch."""

from __future__ import annotations

from robot import interface as ri
from robot.live.groups import (
    ALERTS_KEY,
    AT_LOCATION_KEY,
    DIAGNOSTICS_KEY,
    GOAL_KEY,
    GOAL_STATUS_KEY,
    LATCH_KEY,
    LOCATIONS_KEY,
    MAP_META_KEY,
    MODE_REQUEST_KEY,
    OVERLAY_FOOTPRINT_KEY,
    OVERLAY_GLOBAL_COSTMAP_KEY,
    OVERLAY_LOCAL_COSTMAP_KEY,
    OVERLAY_LOCAL_PLAN_KEY,
    OVERLAY_PARTICLES_KEY,
    OVERLAY_SCAN_KEY,
    OVERLAY_SONAR_KEY,
    SMACH_ACTIVE_KEY,
    SMACH_GRAPH_KEY,
)

# Keys the server itself writes to the latest-state store (not ROS topics), same frames.
NAVIGATION_KEYS = (MAP_META_KEY, GOAL_KEY, GOAL_STATUS_KEY, LOCATIONS_KEY, AT_LOCATION_KEY)
INTROSPECTION_KEYS = (SMACH_GRAPH_KEY, SMACH_ACTIVE_KEY, DIAGNOSTICS_KEY)
# Map overlays: each made by the link from these robot topics, subscribed while a page shows it
# (the robot's pose is always subscribed; tf places frames other than the map's and the base's).
OVERLAY_SOURCES: dict[str, tuple[str, ...]] = {
    OVERLAY_SCAN_KEY: ("scan", "tf_static"),
    OVERLAY_SONAR_KEY: ("sonar", "tf_static"),
    OVERLAY_PARTICLES_KEY: ("particlecloud",),
    OVERLAY_FOOTPRINT_KEY: ("footprint", "tf", "tf_static"),
    OVERLAY_LOCAL_PLAN_KEY: ("local_plan", "tf", "tf_static"),
    OVERLAY_GLOBAL_COSTMAP_KEY: ("global_costmap", "global_costmap_updates", "tf", "tf_static"),
    OVERLAY_LOCAL_COSTMAP_KEY: ("local_costmap", "local_costmap_updates", "tf", "tf_static"),
}
SERVER_KEYS = frozenset({
    MODE_REQUEST_KEY, LATCH_KEY, ALERTS_KEY, *NAVIGATION_KEYS, *INTROSPECTION_KEYS, *OVERLAY_SOURCES})

# The dashboard home.
HOME_KEYS = (
    "battery_soc", "battery_voltage", "battery_recharge_state", "motors_state", "robot_mode",
    "state_change", "state_transitions", "emotional_state", "emotion_system_status",
    "text_to_speech", "tts_feedback", "current_location", "rosout", "robot_pose",
    "smach_status", MODE_REQUEST_KEY, AT_LOCATION_KEY, DIAGNOSTICS_KEY, "bumper_state", OVERLAY_SONAR_KEY,
)
# The state machine page: the graph, what is active, and the events on offer.
STATEMACHINE_KEYS = (SMACH_GRAPH_KEY, SMACH_ACTIVE_KEY, "state_change", "state_transitions")
# The diagnostics page.
DIAGNOSTICS_PAGE_KEYS = (DIAGNOSTICS_KEY,)
# The map page: the robot's position, plan and motors (goals wait for them), besides the server's own navigation keys.
MAP_PAGE_KEYS = ("robot_pose", "plan", "current_location", "bumper_state", "motors_state", *NAVIGATION_KEYS)
# The drive page.
DRIVE_KEYS = ("odom", "robot_pose", "motors_state")
# The map page's overlays, each switched on and off by the operator (dashboard.preferences).
MAP_OVERLAY_KEYS = tuple(OVERLAY_SOURCES)
# What the state API reports.
STATE_KEYS = HOME_KEYS

# Whole occupancy grids are far too big for a browser socket; the map page gets an image.
_BULKY_TYPES = {"nav_msgs/OccupancyGrid"}


def watchable_keys() -> set[str]:
    return {t.key for t in ri.topics() if t.type not in _BULKY_TYPES | ri.SOUND_TYPES} | SERVER_KEYS


def upstream_topics(key: str) -> tuple[str, ...]:
    """The robot topics (interface keys) a page watching ``key`` needs the link to subscribe to."""
    if key in OVERLAY_SOURCES:
        return OVERLAY_SOURCES[key]
    return () if key in SERVER_KEYS else (key,)
