"""The command tool: state machine events, speech, emotion, emotion system, sound, dome.

Each command is ``a<verb>(*, user, source, <value>)``: it runs through ``arun_command``
(role check, audit) and validates inside the run, before anything is published, so a
refusal for bad input is audited like any other failure. All of them publish one
``std_msgs/String``; they differ in the check, the topic and the words of the outcome.
"""

from __future__ import annotations

import inspect
from collections.abc import Awaitable, Callable
from typing import Any

from robot import interface as ri
from robot.commands import validation as v
from robot.commands.pipeline import arun_command
from robot.link import bus
from robot.teleop.latch import ensure_released


async def _send_string(
    *, user: Any, source: str, action: str, field: str, value: Any, key: str,
    clean: Callable[[Any], str | Awaitable[str]], outcome: Callable[[str], str],
) -> str:
    async def run() -> str:
        data = clean(value)
        if inspect.isawaitable(data):
            data = await data
        await bus.apublish(key, {"data": data})
        return outcome(data)

    return await arun_command(user=user, source=source, action=action, params={field: value}, run=run)


def _switch(on: Any) -> str:
    return ri.EMOTION_SYSTEM_ON if v.clean_bool(on, "on") else ri.EMOTION_SYSTEM_OFF


async def asend_event(*, user: Any, source: str, event: Any) -> str:
    async def clean(value: Any) -> str:
        event_name = v.clean_event(value)
        await ensure_released()  # an event can start a behaviour or a demo: a mode change by another name
        return event_name

    return await _send_string(user=user, source=source, action="event", field="event", value=event,
                              key="register_event", clean=clean, outcome=lambda e: f"Sent event {e}")


async def asay(*, user: Any, source: str, text: Any) -> str:
    return await _send_string(user=user, source=source, action="speech", field="text", value=text,
                              key="text_to_speech", clean=v.clean_speech,
                              outcome=lambda t: f"Queued {len(t)} characters for speech")


async def aset_emotion(*, user: Any, source: str, emotion: Any) -> str:
    return await _send_string(user=user, source=source, action="emotion", field="emotion", value=emotion,
                              key="set_emotional_state", clean=v.clean_emotion, outcome=lambda e: f"Set emotion {e}")


async def aset_emotion_system(*, user: Any, source: str, on: Any) -> str:
    return await _send_string(user=user, source=source, action="emotion_system", field="on", value=on,
                              key="emotional_controller", clean=_switch,
                              outcome=lambda s: f"Emotion system {s.lower()}")


async def aplay_clip(*, user: Any, source: str, clip: Any) -> str:
    return await _send_string(user=user, source=source, action="playback", field="clip", value=clip,
                              key="playback", clean=v.clean_clip, outcome=lambda c: f"Playing {c}")


async def aset_dome(*, user: Any, source: str, mode: Any) -> str:
    return await _send_string(user=user, source=source, action="dome", field="mode", value=mode,
                              key="domecontrol", clean=v.clean_dome_mode, outcome=lambda d: f"Dome mode {d}")
