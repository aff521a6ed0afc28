"""What a fresh installation records, so the ready-made plots have data from the first day."""

from __future__ import annotations

from history.models import Mode, TopicPolicy
from robot import interface as ri

DAY_S = 24 * 3600.0

# key -> (mode, interval_s or None for the global default, retention_s). Enough to replay the last
# day (history.replay): the pose twice a second, odometry and the plan, every state change, mode,
# log line and map, the status of goals, diagnostics and bumpers.
DEFAULT_POLICIES: dict[str, tuple[str, float | None, float]] = {
    "battery_soc": (Mode.PERIODIC, 10.0, 30 * DAY_S),
    "battery_voltage": (Mode.PERIODIC, 10.0, 30 * DAY_S),
    "emotional_state": (Mode.PERIODIC, 2.0, 30 * DAY_S),
    "robot_pose": (Mode.PERIODIC, 0.5, 7 * DAY_S),
    "odom": (Mode.PERIODIC, 1.0, 2 * DAY_S),
    "plan": (Mode.PERIODIC, 2.0, 2 * DAY_S),
    "move_base_status": (Mode.PERIODIC, 1.0, 7 * DAY_S),
    "diagnostics": (Mode.PERIODIC, 5.0, 7 * DAY_S),
    "bumper_state": (Mode.PERIODIC, 1.0, 7 * DAY_S),
    "motors_state": (Mode.PERIODIC, 5.0, 7 * DAY_S),
    "map": (Mode.EVERY, None, 90 * DAY_S),
    "state_change": (Mode.EVERY, None, 90 * DAY_S),
    "robot_mode": (Mode.EVERY, None, 90 * DAY_S),
    "text_to_speech": (Mode.EVERY, None, 30 * DAY_S),
    "rosout": (Mode.EVERY, None, 7 * DAY_S),
}
# A map is a big message (a 4000 x 4000 grid is 16 MB of cells); it changes rarely.
DEFAULT_MAX_BYTES: dict[str, int] = {"map": 64 * 1024 * 1024}


def ensure_default_policies() -> int:
    """Create the default policies that don't exist yet, named and typed for the ROS the robot runs
    (never overrides an admin's choice). A default kept with the other ROS's spelling of its type (the
    same name on both, as ``/rosout``) takes this ROS's: the spelling is the robot's, not a choice."""
    created = 0
    for key, (mode, interval_s, retention_s) in DEFAULT_POLICIES.items():
        topic = ri.topic(key)
        policy, made = TopicPolicy.objects.get_or_create(
            topic=topic.name,
            defaults={"msg_type": topic.type, "mode": mode, "interval_s": interval_s, "retention_s": retention_s,
                      "max_message_bytes": DEFAULT_MAX_BYTES.get(key)},
        )
        created += made
        other_spellings = {ri.topic(key, ros).type for ros in ri.ROS_VERSIONS} - {topic.type}
        if policy.msg_type in other_spellings:
            TopicPolicy.objects.filter(pk=policy.pk).update(msg_type=topic.type)
    return created
