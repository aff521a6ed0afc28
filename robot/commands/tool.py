"""The command tool: state machine events, speech, emotion, emotion system, sound, dome.

Each command publishes one ``std_msgs/String``; they differ in the check, the topic and the
words of the outcome, one row of ``STRING_COMMANDS`` each. ``string_command(action, value)``
returns a ``Command`` that either face of the pipeline runs (``run_command`` from the API,
``arun`` from async code). The input is checked before anything is published, so a refusal for
bad input is audited like any other failure; checks that read no database (events, speech, the
emotion switch; not the presets) may run on the event loop.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from robot import interface as ri
from robot.commands import validation as v
from robot.commands.pipeline import Command
from robot.link import bus


def _switch(on: Any) -> str:
    return ri.EMOTION_SYSTEM_ON if v.clean_bool(on, "on") else ri.EMOTION_SYSTEM_OFF


# action -> (its audited field, the topic key, the check, the outcome's words, the check reads no database)
STRING_COMMANDS: dict[str, tuple[str, str, Callable[[Any], str], Callable[[str], str], bool]] = {
    "event": ("event", "register_event", v.clean_event, lambda e: f"Sent event {e}", True),
    "speech": ("text", "text_to_speech", v.clean_speech, lambda t: f"Queued {len(t)} characters for speech", True),
    "emotion": ("emotion", "set_emotional_state", v.clean_emotion, lambda e: f"Set emotion {e}", False),
    "emotion_system": ("on", "emotional_controller", _switch, lambda s: f"Emotion system {s.lower()}", True),
    "playback": ("clip", "playback", v.clean_clip, lambda c: f"Playing {c}", False),
    "dome": ("mode", "domecontrol", v.clean_dome_mode, lambda d: f"Dome mode {d}", False),
}


def string_command(action: str, value: Any) -> Command:
    field, key, clean, outcome, check_on_loop = STRING_COMMANDS[action]

    async def send(data: str) -> str:
        await bus.apublish(key, {"data": data})
        return outcome(data)

    return Command(action, {field: value}, send, check=lambda: clean(value), check_on_loop=check_on_loop)
