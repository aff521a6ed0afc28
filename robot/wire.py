"""Decoding large rosbridge frames fast, and encoding what they decode to.

A 4000 x 4000 map arrives as one ~32 MB JSON text frame whose ``data`` is 16 million
integers. ``json.loads`` turns that into 16 million Python ints (~0.7 s) that numpy then
has to copy again (~0.25 s). rosbridge writes the grid's ``data`` last, so the frame ends
with that one integer array: ``decode_frame`` cuts it out, parses it with numpy in chunks
(~0.2 s, and the GIL is free between chunks so the server's event loop keeps running),
and parses the small rest with ``json``. Any frame that does not have that shape is
decoded by ``json`` as usual, so the fast path can only be faster, never different.
"""

from __future__ import annotations

import json
import re
from typing import Any

import numpy as np

LARGE_FRAME_BYTES = 1 << 20  # frames from this size on are decoded off the event loop
_CHUNK_BYTES = 1 << 21  # ~1 M values per numpy call: short GIL holds
_TOPIC = re.compile(rb'"topic"\s*:\s*"([^"\\]*)"')
_INT_CHARS = b"0123456789,- \t\r\n"
_SENTINEL = "\x00cyborg-int-array\x00"


def frame_topic(payload: bytes) -> str | None:
    """The ``topic`` of a publish frame, read from its first bytes (rosbridge writes it before ``msg``)."""
    match = _TOPIC.search(payload, 0, 512)
    return match.group(1).decode() if match else None


def decode_frame(payload: bytes, *, array_topics: frozenset[str] = frozenset()) -> dict[str, Any]:
    """The frame as a dict; a trailing integer array of a topic in ``array_topics`` becomes an ndarray."""
    if frame_topic(payload) in array_topics:
        split = _split_trailing_int_array(payload)
        if split is not None:
            head, array = split
            frame = json.loads(head)
            if _put_array(frame, array):
                return frame
    return json.loads(payload)


def parse_int_array(body: bytes) -> np.ndarray | None:
    """``1,-1,100`` (the inside of a JSON array of integers) as int32; None if it is anything else."""
    if not body.strip():
        return np.zeros(0, dtype=np.int32)
    if body.translate(None, _INT_CHARS):
        return None  # floats, strings, nested arrays...
    parts = []
    start = 0
    while start < len(body):
        end = body.find(b",", start + _CHUNK_BYTES) if len(body) - start > _CHUNK_BYTES else -1
        chunk = body[start:] if end < 0 else body[start:end]
        try:
            parts.append(np.fromstring(chunk.decode("ascii"), dtype=np.int32, sep=","))
        except ValueError:
            return None
        start = len(body) if end < 0 else end + 1
    array = np.concatenate(parts) if len(parts) > 1 else parts[0]
    # numpy stops quietly at the first malformed value ("1,,2"), so check that every value was read.
    return array if array.size == body.count(b",") + 1 else None


def _split_trailing_int_array(payload: bytes) -> tuple[str, np.ndarray] | None:
    """(the frame with its last array replaced by a sentinel, that array) when the frame ends with it."""
    opening = payload.rfind(b"[")
    closing = payload.find(b"]", opening)
    if opening < 0 or closing < 0 or payload[closing + 1:].strip(b"} \t\r\n"):
        return None
    if not payload[:opening].rstrip().endswith(b":"):
        return None  # a "[" inside a string
    array = parse_int_array(payload[opening + 1:closing])
    if array is None:
        return None
    head = payload[:opening].decode("utf8") + json.dumps(_SENTINEL) + payload[closing + 1:].decode("utf8")
    return head, array


def _put_array(node: Any, array: np.ndarray) -> bool:
    if isinstance(node, dict):
        for key, value in node.items():
            if value == _SENTINEL:
                node[key] = array
                return True
            if isinstance(value, dict | list) and _put_array(value, array):
                return True
    elif isinstance(node, list):
        return any(_put_array(item, array) for item in node)
    return False


def jsonable(value: Any) -> Any:
    """``default`` for ``json.dumps``: decoded arrays back to lists (when someone records the map)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"Object of type {type(value).__name__} is not JSON serializable")
