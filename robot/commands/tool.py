"""The command tool: state machine events, speech, emotion, emotion system, sound, dome.

Each command is ``a<verb>(*, user, source, <value>)``: it runs through ``arun_command``
(role check, audit) and validates inside the run, before anything is published, so a
refusal for bad input is audited like any other failure.
"""

from __future__ import annotations

from typing import Any

from robot import bus
from robot import interface as ri
from robot.commanding import arun_command
from robot.commands import validation as v


async def asend_event(*, user: Any, source: str, event: Any) -> str:
    async def run() -> str:
        name = v.clean_event(event)
        await bus.apublish("register_event", {"data": name})
        return f"Sent event {name}"

    return await arun_command(user=user, source=source, action="event", params={"event": event}, run=run)


async def asay(*, user: Any, source: str, text: Any) -> str:
    async def run() -> str:
        clean = v.clean_speech(text)
        await bus.apublish("text_to_speech", {"data": clean})
        return f"Queued {len(clean)} characters for speech"

    return await arun_command(user=user, source=source, action="speech", params={"text": text}, run=run)


async def aset_emotion(*, user: Any, source: str, emotion: Any) -> str:
    async def run() -> str:
        name = await v.clean_emotion(emotion)
        await bus.apublish("set_emotional_state", {"data": name})
        return f"Set emotion {name}"

    return await arun_command(user=user, source=source, action="emotion", params={"emotion": emotion}, run=run)


async def aset_emotion_system(*, user: Any, source: str, on: Any) -> str:
    async def run() -> str:
        enabled = v.clean_bool(on, "on")
        await bus.apublish("emotional_controller", {"data": ri.EMOTION_SYSTEM_ON if enabled else ri.EMOTION_SYSTEM_OFF})
        return f"Emotion system {'on' if enabled else 'off'}"

    return await arun_command(user=user, source=source, action="emotion_system", params={"on": on}, run=run)


async def aplay_clip(*, user: Any, source: str, clip: Any) -> str:
    async def run() -> str:
        name = await v.clean_clip(clip)
        await bus.apublish("playback", {"data": name})
        return f"Playing {name}"

    return await arun_command(user=user, source=source, action="playback", params={"clip": clip}, run=run)


async def aset_dome(*, user: Any, source: str, mode: Any) -> str:
    async def run() -> str:
        name = await v.clean_dome_mode(mode)
        await bus.apublish("domecontrol", {"data": name})
        return f"Dome mode {name}"

    return await arun_command(user=user, source=source, action="dome", params={"mode": mode}, run=run)
