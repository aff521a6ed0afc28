"""The controller's SMACH state machine (ROBOT_INTERFACE.md, "The state machine").

States are tracked as leaf names; the behaviour container and, inside it, the navigation
container are flattened into their leaves. ``state_change`` names the leaf entered, so
entering behaviour reports ``idle`` (SMACH runs the container's initial state).
"""

from __future__ import annotations

import json
from collections.abc import Callable

SUSPENSION = "suspension"
LEAVE = SUSPENSION  # leaving the behaviour container ends in suspension

TOP: dict[str, dict[str, str]] = {
    "startup": {"succeeded": SUSPENSION, "aborted": SUSPENSION},
    "suspension": {"behaviour_start": "idle", "restart": "startup", "demo_start": "demo",
                   "manual_start": "manual", "aborted": SUSPENSION, "succeeded": SUSPENSION},
    "demo": {"succeeded": SUSPENSION, "aborted": SUSPENSION},
    "manual": {"succeeded": SUSPENSION, "aborted": SUSPENSION},
}

_BACK = {"succeeded": "idle", "aborted": "idle"}
_NAV_OUT = {"succeeded": "idle", "aborted": "idle", "power_low": "exhausted"}
NAVIGATION_LEAVES = ("navigation_planning", "navigation_go_to_emotional", "navigation_go_to_schedular",
                     "wandering_emotional")

BEHAVIOUR: dict[str, dict[str, str]] = {
    "idle": {"suspend": LEAVE, "navigation_schedular": "navigation_planning",
             "navigation_emotional": "navigation_planning", "convey_emotion": "conveying_emotional_state",
             "show_off_mea": "show_off_mea", "music_play": "music_horror", "astrolanguage": "astrolanguage",
             "aborted": "idle", "power_low": "exhausted", "bedtime": "sleepy"},
    "show_off_mea": dict(_BACK),
    "conveying_emotional_state": dict(_BACK),
    "music_horror": dict(_BACK),
    "astrolanguage": dict(_BACK),
    "waking_up": dict(_BACK),
    "sleepy": {"aborted": "idle", "succeeded": "sleeping"},
    "exhausted": {"aborted": "idle", "succeeded": "sleeping"},
    "sleeping": {"preempted": "idle", "cyborg_wake_up": "waking_up"},
    # navigation container: planning picks the leaf from the event that entered it
    "navigation_planning": {**_NAV_OUT, "navigation_go_to_emotional": "navigation_go_to_emotional",
                            "navigation_go_to_schedular": "navigation_go_to_schedular",
                            "wandering_emotional": "wandering_emotional"},
    "navigation_go_to_emotional": dict(_NAV_OUT),
    "navigation_go_to_schedular": dict(_NAV_OUT),
    "wandering_emotional": dict(_NAV_OUT),
}

TABLE: dict[str, dict[str, str]] = {**TOP, **BEHAVIOUR}
BEHAVIOUR_STATES = frozenset(BEHAVIOUR)


class StateMachine:
    def __init__(self, on_change: Callable[[str, str, str], None], initial: str = "startup") -> None:
        self.state = initial
        self.on_change = on_change
        self.entered_by: str = ""

    @property
    def top(self) -> str:
        """The top-level state (``behaviour`` for any leaf inside the container)."""
        return "behaviour" if self.state in BEHAVIOUR_STATES else self.state

    def accepts(self, event: str) -> bool:
        return event in TABLE[self.state]

    def fire(self, event: str) -> bool:
        """Apply ``event``; False (nothing happens) if the current state has no such transition."""
        target = TABLE[self.state].get(event)
        if target is None:
            return False
        previous, self.state, self.entered_by = self.state, target, event
        self.on_change(event, previous, target)
        return True

    def transitions_json(self) -> str:
        """What ``state_transitions`` publishes: {event: resulting state} of the state entered.
        Inside the navigation container the container's own name is the observable target."""
        return json.dumps(TABLE[self.state])

    def smach_status(self) -> list[tuple[str, list[str], list[str]]]:
        """(path, initial_states, active_states) of each active container."""
        out = [("/SM_ROOT", ["startup"], [self.top])]
        if self.state in BEHAVIOUR_STATES:
            leaf = "navigation" if self.state in NAVIGATION_LEAVES else self.state
            out.append(("/SM_ROOT/behaviour", ["idle"], [leaf]))
            if self.state in NAVIGATION_LEAVES:
                out.append(("/SM_ROOT/behaviour/navigation", ["navigation_planning"], [self.state]))
        return out

    @staticmethod
    def smach_structure() -> list[tuple[str, list[str], list[tuple[str, str, str]], list[str]]]:
        """(path, children, [(from, outcome, to)], container outcomes) of each container."""
        root = [(s, e, t if t != "idle" else "behaviour") for s, tr in TOP.items() for e, t in tr.items()]
        root.append(("behaviour", "succeeded", SUSPENSION))
        inner = [(s, e, "succeeded" if t == LEAVE else "navigation" if t in NAVIGATION_LEAVES else t)
                 for s, tr in BEHAVIOUR.items() if s not in NAVIGATION_LEAVES for e, t in tr.items()]
        # The navigation leaves end in the navigation container's outcomes, which the behaviour
        # container maps to its states (as SMACH wires a nested container).
        inner += [("navigation", e, t) for e, t in _NAV_OUT.items()]
        nav = [(s, e, t if t in NAVIGATION_LEAVES else e) for s, tr in BEHAVIOUR.items()
               if s in NAVIGATION_LEAVES for e, t in tr.items()]
        behaviour_children = [s for s in BEHAVIOUR if s not in NAVIGATION_LEAVES] + ["navigation"]
        return [
            ("/SM_ROOT", [*TOP, "behaviour"], root, []),
            ("/SM_ROOT/behaviour", behaviour_children, inner, ["succeeded"]),
            ("/SM_ROOT/behaviour/navigation", list(NAVIGATION_LEAVES), nav, ["succeeded", "aborted", "power_low"]),
        ]
