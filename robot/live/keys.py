"""Which latest-state keys each page (and the state API) watches, and which a page may watch."""

from __future__ import annotations

from robot import interface as ri
from robot.live.groups import (
    AT_LOCATION_KEY,
    GOAL_KEY,
    GOAL_STATUS_KEY,
    LATCH_KEY,
    LOCATIONS_KEY,
    MAP_META_KEY,
    MODE_REQUEST_KEY,
)

# Keys the server itself writes to the latest-state store (not ROS topics), same frames.
NAVIGATION_KEYS = (MAP_META_KEY, GOAL_KEY, GOAL_STATUS_KEY, LOCATIONS_KEY, AT_LOCATION_KEY)
SERVER_KEYS = frozenset({MODE_REQUEST_KEY, LATCH_KEY, *NAVIGATION_KEYS})

# The dashboard home.
HOME_KEYS = (
    "battery_soc", "battery_voltage", "battery_recharge_state", "motors_state", "robot_mode",
    "state_change", "state_transitions", "emotional_state", "emotion_system_status",
    "text_to_speech", "tts_feedback", "current_location", "rosout", "robot_pose",
    "smach_status", MODE_REQUEST_KEY, AT_LOCATION_KEY,
)
# The map page: the robot's position and plan, besides the server's own navigation keys.
MAP_PAGE_KEYS = ("robot_pose", "plan", "current_location", *NAVIGATION_KEYS)
# The drive page.
DRIVE_KEYS = ("odom", "robot_pose", "motors_state")
# What the state API reports.
STATE_KEYS = HOME_KEYS

# Whole occupancy grids are far too big for a browser socket; the map page gets an image.
_BULKY_TYPES = {"nav_msgs/OccupancyGrid"}


def watchable_keys() -> set[str]:
    return {t.key for t in ri.topics() if t.type not in _BULKY_TYPES} | SERVER_KEYS
