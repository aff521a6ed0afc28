"""The talk lock: one voice on the robot's speakers at a time, across every web process.

A held lock (``robot.live.locks``) like the drive lock, under a name of its own, with a
short time-to-live refreshed while audio flows, so a web process that dies mid-talk frees
it within seconds. Every change is announced to every audio socket through one group.
"""

from __future__ import annotations

from functools import cache
from typing import Any, Literal, TypedDict

from channels.layers import get_channel_layer
from django.conf import settings

from robot.live.groups import TALK_GROUP
from robot.live.locks import HeldLock, Holder, held_lock


class TalkEvent(TypedDict):
    type: Literal["audio.talk"]
    holder: str | None  # username
    owner: str | None  # the talking connection
    reason: str  # start | stop | quiet | disconnect | estop | offline | refused


@cache
def get_talk_lock() -> HeldLock:
    return held_lock("talk-lock", settings.AUDIO_TALK_LOCK_TTL_S)


reset_talk_lock = get_talk_lock.cache_clear  # forget the configured lock (tests that change settings)


async def announce_talker(holder: Holder | None, reason: str) -> None:
    event: TalkEvent = {
        "type": "audio.talk", "holder": holder.username if holder else None,
        "owner": holder.owner if holder else None, "reason": reason,
    }
    await get_channel_layer().group_send(TALK_GROUP, event)


async def end_all_talk(by: str = "") -> str:
    """The E-STOP's step: free the talk lock; the talker's socket stops on the announcement."""
    previous = await get_talk_lock().clear()
    await announce_talker(None, "estop")
    return f"{previous.username} stopped talking" if previous else "nobody was talking"


def talk_view(holder: str | None, owner: str | None, me: Holder, reason: str = "") -> dict[str, Any]:
    return {"type": "talker", "holder": holder, "you": owner == me.owner, "reason": reason}
