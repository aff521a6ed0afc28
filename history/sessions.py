"""The robot link's sessions in the recording, so the state timeline knows when the robot was away.

The recorder notes every change of the link's connection (at the time the link saw it) and, while
the robot is away, a beat every ``OFFLINE_BEAT_S``: the outage is time the recording covers (the
recorder was there and knew), booked as "offline", unlike time when nothing was recorded at all.
After a reconnect the robot's state is unknown until its next transition names the state it
left (after a restart: ``startup``), so nothing from before the restart is carried over it."""

from __future__ import annotations

from history.storage import Pending

SESSION_TOPIC = "/cyborg_commander/robot_link"
SESSION_TYPE = "cyborg_commander/RobotLinkSession"
OFFLINE = "offline"
OFFLINE_BEAT_S = 60.0  # well under the timeline's gap (history.selectors.GAP_S)


class SessionNotes:
    """What the recorder writes about the link: call ``note`` every flush with the link's state."""

    def __init__(self) -> None:
        self.connected: bool | None = None
        self.beat_at = 0.0

    def note(self, *, connected: bool, since: float, now: float) -> list[Pending]:
        if connected != self.connected:
            self.connected, self.beat_at = connected, now
        elif not connected and now - self.beat_at >= OFFLINE_BEAT_S:
            self.beat_at = since = now
        else:
            return []
        return [(SESSION_TOPIC, SESSION_TYPE, {"connected": connected}, since)]
