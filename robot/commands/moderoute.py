"""The way from any state of the state machine to any mode (ROBOT_INTERFACE.md, "The state machine").

The thesis's commander sequences assume the robot is outside the behaviour container: from
inside it, their ``aborted`` only returns to idle and the mode's start event is ignored. So the
commander first walks the state machine out, one checked step at a time, to suspension, and
enters the target mode from there.
"""

from __future__ import annotations

from dataclasses import dataclass

from robot import interface as ri

SUSPENSION = ri.State.SUSPENSION.value
IDLE = ri.State.IDLE.value


@dataclass(frozen=True)
class Step:
    event: str
    from_state: str
    to_state: str  # where the event should lead; "" when the starting state is unknown

    def describe(self) -> str:
        start = self.from_state or "an unknown state"
        return f"event {self.event} ({start} → {self.to_state or 'any state'})"


def in_behaviour(state: str) -> bool:
    """Is ``state`` inside the behaviour container (any of its leaves, however nested)?"""
    return bool(state) and state not in ri.TOP_LEVEL_STATES


def way_out(state: str) -> Step | None:
    """The next step from ``state`` towards suspension; None once there."""
    if state == SUSPENSION:
        return None
    if not state:
        return Step(ri.Event.ABORTED, "", "")
    if state in ri.TOP_LEVEL_STATES:
        return Step(ri.Event.ABORTED, state, SUSPENSION)
    if state == IDLE:
        return Step(ri.Event.SUSPEND, state, SUSPENSION)
    if state == ri.SLEEPING_STATE:
        return Step(ri.Event.PREEMPTED, state, IDLE)
    return Step(ri.Event.ABORTED, state, IDLE)


def way_in(mode: ri.Mode) -> Step | None:
    """The step from suspension into ``mode``; None for stop (suspension is its target)."""
    event = ri.MODE_ENTRY[mode][1]
    if event is None:
        return None
    target = ri.MODE_TARGET_STATE[mode].value
    return Step(event, SUSPENSION, IDLE if target == ri.State.BEHAVIOUR.value else target)
