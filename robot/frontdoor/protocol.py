"""rosbridge v2 frames as the front door reads and writes them: plain functions, no I/O.

What a client sends is checked here field by field (a ROS 1 rosbridge drops a bad frame silently;
the front door answers it with a ``status`` error naming the field instead). What goes out is built
once per process where it can be: a topic's message arrives as the hub's pre-serialised fragment
and becomes a ``publish`` frame by slicing, never by decoding and encoding again.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any

_COMPACT = (",", ":")
COMPRESSIONS = frozenset({"none", "cbor", "cbor-raw", "png"})


class BadFrame(ValueError):
    """A frame the front door will not act on; the message says why (sent back as a status error)."""


@dataclass(frozen=True)
class Subscribe:
    id: str | None
    topic: str
    type: str | None
    throttle_rate: int  # ms; 0 = as the server paces it
    queue_length: int
    fragment_size: int | None
    compression: str


def parse(text: str | bytes) -> dict[str, Any]:
    try:
        frame = json.loads(text)
    except ValueError:
        raise BadFrame("not a JSON object") from None
    if not isinstance(frame, dict):
        raise BadFrame("not a JSON object")
    if not isinstance(frame.get("op"), str):
        raise BadFrame("a frame needs an op")
    return frame


def frame_id(frame: dict[str, Any]) -> str | None:
    value = frame.get("id")
    return str(value) if value is not None else None


def text(frame: dict[str, Any], name: str, *, required: bool = True) -> str | None:
    value = frame.get(name)
    if value is None and not required:
        return None
    if not isinstance(value, str) or not value:
        raise BadFrame(f"{name} must be a non-empty string")
    return value


def whole_number(frame: dict[str, Any], name: str, default: int | None) -> int | None:
    value = frame.get(name, default)
    if value is None:
        return default
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise BadFrame(f"{name} must be a whole number of at least 0")
    return value


def subscribe(frame: dict[str, Any]) -> Subscribe:
    compression = frame.get("compression") or "none"
    if compression not in COMPRESSIONS:
        raise BadFrame(f"compression must be one of {', '.join(sorted(COMPRESSIONS))}")
    fragment_size = whole_number(frame, "fragment_size", None)
    return Subscribe(
        id=frame_id(frame), topic=str(text(frame, "topic")), type=text(frame, "type", required=False),
        throttle_rate=whole_number(frame, "throttle_rate", 0) or 0,
        queue_length=whole_number(frame, "queue_length", 0) or 0,
        fragment_size=fragment_size or None, compression=str(compression),
    )


def args(frame: dict[str, Any]) -> dict[str, Any]:
    """A call's arguments by name (positional lists only when empty: the front door checks by name)."""
    value = frame.get("args")
    if value is None or value == []:
        return {}
    if not isinstance(value, dict):
        raise BadFrame("args must be an object of named fields")
    return value


def finite(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise BadFrame(f"{name} must be a finite number")
    return float(value)


# --- what goes out -------------------------------------------------------------------


def dumps(frame: dict[str, Any]) -> str:
    return json.dumps(frame, separators=_COMPACT)


def status(level: str, msg: str, id: str | None = None) -> str:
    frame: dict[str, Any] = {"op": "status", "level": level, "msg": msg}
    if id is not None:
        frame["id"] = id
    return dumps(frame)


def service_response(service: str, id: str | None, values: Any, result: bool) -> str:
    frame: dict[str, Any] = {"op": "service_response", "service": service, "values": values, "result": result}
    if id is not None:
        frame["id"] = id
    return dumps(frame)


_last: tuple[str, str] = ("", "")


def publish_from_fragment(topic: str, fragment: str) -> str:
    """The hub's ``{"key":…,"msg":…,"t":…}`` as rosbridge's ``{"op":"publish","topic":…,"msg":…}``:
    sliced, and made once per update however many clients get it (the hub hands each the same text)."""
    global _last
    if _last[0] is fragment:
        return _last[1]
    start = fragment.index(',"msg":')
    end = fragment.rindex(',"t":')
    frame = '{"op":"publish","topic":' + json.dumps(topic) + fragment[start:end] + "}"
    _last = (fragment, frame)
    return frame


def fragments(frame: str, size: int, id: str) -> list[str]:
    """``frame`` cut into rosbridge ``fragment`` frames of at most ``size`` characters of data."""
    parts = [frame[i:i + size] for i in range(0, len(frame), size)] or [""]
    return [dumps({"op": "fragment", "id": id, "data": part, "num": n, "total": len(parts)})
            for n, part in enumerate(parts)]
