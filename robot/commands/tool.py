"""The command tool: state machine events, speech, emotion, emotion system, sound, dome.

Each command is a builder (``say(text)``, ``set_emotion(name)``…) returning a ``Command`` that
either face of the pipeline runs (``run_command`` from the API, ``arun`` from async code).
The input is checked before anything is published, so a refusal for bad input is audited
like any other failure; checks that read no database (events, speech, the emotion switch; not
the presets) may run on the event loop. All of them publish one ``std_msgs/String``; they differ in the
check, the topic and the words of the outcome.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from robot import interface as ri
from robot.commands import validation as v
from robot.commands.pipeline import Command
from robot.link import bus


def _string_command(
    *, action: str, field: str, value: Any, key: str, clean: Callable[[Any], str], outcome: Callable[[str], str],
    check_on_loop: bool = False,
) -> Command:
    async def send(data: str) -> str:
        await bus.apublish(key, {"data": data})
        return outcome(data)

    return Command(action, {field: value}, send, check=lambda: clean(value), check_on_loop=check_on_loop)


def _switch(on: Any) -> str:
    return ri.EMOTION_SYSTEM_ON if v.clean_bool(on, "on") else ri.EMOTION_SYSTEM_OFF


def send_event(value: Any) -> Command:
    return _string_command(action="event", field="event", value=value, key="register_event", clean=v.clean_event,
                           outcome=lambda e: f"Sent event {e}", check_on_loop=True)


def say(text: Any) -> Command:
    return _string_command(action="speech", field="text", value=text, key="text_to_speech", clean=v.clean_speech,
                           outcome=lambda t: f"Queued {len(t)} characters for speech", check_on_loop=True)


def set_emotion(value: Any) -> Command:
    return _string_command(action="emotion", field="emotion", value=value, key="set_emotional_state",
                           clean=v.clean_emotion, outcome=lambda e: f"Set emotion {e}")


def set_emotion_system(on: Any) -> Command:
    return _string_command(action="emotion_system", field="on", value=on, key="emotional_controller", clean=_switch,
                           outcome=lambda s: f"Emotion system {s.lower()}", check_on_loop=True)


def play_clip(clip: Any) -> Command:
    return _string_command(action="playback", field="clip", value=clip, key="playback", clean=v.clean_clip,
                           outcome=lambda c: f"Playing {c}")


def set_dome(mode: Any) -> Command:
    return _string_command(action="dome", field="mode", value=mode, key="domecontrol", clean=v.clean_dome_mode,
                           outcome=lambda d: f"Dome mode {d}")

