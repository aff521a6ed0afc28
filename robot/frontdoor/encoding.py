"""CBOR frames for clients that ask for them: ``cbor`` (the message as CBOR) and ``cbor-raw`` (the
robot's serialized bytes, ``robot.frontdoor.rawtypes``), each made once per update per process
however many clients take it. The definitions come from the robot's rosapi, asked again (at most
every ``LEARN_AGAIN_S``) when a topic appears that was not known."""

from __future__ import annotations

import json
import logging
import time
from typing import Any

import cbor2

from robot.frontdoor.rawtypes import Serializer, Unknown
from robot.frontdoor.rules import Refused
from robot.link.bus import arequest
from robot.live.frames import ws_frame, ws_text_frame

log = logging.getLogger(__name__)

LEARN_AGAIN_S = 2.0
RAW_TYPES = "/rosapi/topics_and_raw_types"

serializer = Serializer()
_learnt_at = 0.0
_last: tuple[str, dict[str, bytes]] = ("", {})


async def learn(topic: str) -> None:
    """Make sure ``topic``'s type can be serialized; Refused when the robot gives no definition of it."""
    global _learnt_at
    if topic not in serializer.topics and time.monotonic() - _learnt_at >= LEARN_AGAIN_S:
        reply = await arequest("call_service", service=RAW_TYPES, service_type="rosapi/TopicsAndRawTypes")
        values = reply.get("values") or {}
        serializer.learn(list(values.get("topics") or []), list(values.get("types") or []),
                         list(values.get("typedefs_full_text") or []))
        _learnt_at = time.monotonic()
    msg_type = serializer.topics.get(topic)
    if msg_type is None:
        raise Refused(f"the robot has no topic {topic}", "not_found")
    if not serializer.knows(msg_type):
        raise Refused(f"no definition of {msg_type} to serialize for cbor-raw: subscribe without compression",
                      "invalid")


def frame(topic: str, fragment: str, compression: str) -> bytes | None:
    """The CBOR ``publish`` frame of one hub update (``{"key","msg","t"}``), or None when it cannot be made."""
    global _last
    if _last[0] is not fragment:
        _last = (fragment, {})
    made = _last[1].get(compression)
    if made is None:
        try:
            made = _last[1][compression] = _make(topic, json.loads(fragment), compression)
        except (Unknown, ValueError, TypeError, KeyError):
            log.warning("could not make a %s frame of %s", compression, topic, exc_info=True)
            return None
    return made


def _make(topic: str, update: dict[str, Any], compression: str) -> bytes:
    msg = update["msg"]
    if compression == "cbor":
        return cbor2.dumps({"op": "publish", "topic": topic, "msg": msg})
    t = float(update["t"])
    secs = int(t)
    raw = serializer.serialize(serializer.topics[topic], msg)
    return cbor2.dumps({"op": "publish", "topic": topic, "msg": {"secs": secs, "nsecs": int((t - secs) * 1e9),
                                                                   "bytes": raw}})


_frames: dict[int, tuple[str | bytes, bytes]] = {}
FRAMES_KEPT = 256  # recent frames' encodings (clients paced apart write the same one moments apart)


def encoded(frame: str | bytes) -> bytes:
    """``frame`` as a websocket frame (text, or binary for CBOR), encoded once for every client."""
    found = _frames.get(id(frame))
    if found is not None and found[0] is frame:
        return found[1]
    data = ws_frame(frame, 0x82) if isinstance(frame, bytes) else ws_text_frame(frame)
    if len(_frames) >= FRAMES_KEPT:
        del _frames[next(iter(_frames))]
    _frames[id(frame)] = (frame, data)
    return data
