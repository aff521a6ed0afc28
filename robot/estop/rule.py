"""Which commands the E-STOP holds back: every command the pipeline runs is declared here.

A command that moves the robot, changes its mode or motors, or takes the drive or the speaker
is refused (409) while the E-STOP is latched, by the pipeline, before ``send``; the link checks
the latch once more on every publish and service call (``interface.passes_latch``). A command
whose action is not declared here cannot be built, so a new one cannot forget the gate.

Each declaration reads what the command's ``check`` returned (a mode, a switch), because some
commands stop the robot with one input and move it with another.
"""

from __future__ import annotations

from typing import Any

from robot import interface as ri
from robot.commands.pipeline import Declaration


def always(_: Any) -> bool:
    return True


def never(_: Any) -> bool:
    return False


def _not_stop_mode(mode: Any) -> bool:
    return mode is not ri.Mode.STOP


def _switching_on(state: Any) -> bool:
    return state is True or state == ri.EMOTION_SYSTEM_ON


MOVES: dict[str, Declaration] = {
    "estop": never,
    "estop.release": never,
    "mode": _not_stop_mode,
    "event": always,  # an event can start a behaviour or a demo: a mode change by another name
    "speech": never,
    "emotion": never,
    "emotion_system": _switching_on,  # on, it starts behaviours
    "playback": never,
    "dome": never,
    "motors": _switching_on,
    "navigation.goal": always,
    "navigation.cancel": never,
    "navigation.initial_pose": always,  # the robot re-localises and may move to correct itself
    "navigation.go_to": always,
    "teleop.lock": always,
    "teleop.takeover": always,
    "audio.listen.start": never,
    "link.reconnect": never,
    "audio.talk.start": always,  # the E-STOP ends every talk; no new one starts under it
    "frontdoor.publish": always,  # an admin's allowlisted topic: nobody here knows what it does
    "frontdoor.call": always,
}


def declaration(action: str) -> Declaration:
    try:
        return MOVES[action]
    except KeyError:
        raise LookupError(
            f"command {action!r} is not declared in robot.estop.rule.MOVES: say whether it moves the robot"
        ) from None
