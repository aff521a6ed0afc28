"""Decoding large rosbridge frames fast.

A 4000 x 4000 map arrives as one ~32 MB JSON text frame whose ``data`` is 16 million
integers. ``json.loads`` turns that into 16 million Python ints (~0.7 s) that numpy then
has to copy again (~0.25 s). ``decode_frame`` cuts the frame's big ``"data": [...]``
integer array out, parses it with numpy in chunks (~0.2 s, and the GIL is free between
chunks so the server's event loop keeps running), and parses the small rest with
``json``. It does not rely on key order or spacing: rosbridge writes with ujson when it
has it (compact, ``\\/`` for ``/``), and on Python 2 keys come in hash order. A frame without such
an array is decoded by ``json`` as usual, so the fast path is only faster, never different.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from typing import Any

import numpy as np

LARGE_FRAME_BYTES = 1 << 20  # frames from this size on are decoded off the event loop
_CHUNK_BYTES = 1 << 21  # ~1 M values per numpy call: short GIL holds
_DATA_KEY = b'"data"'
_THEN_ARRAY = re.compile(rb"\s*:\s*\[")
_INT_CHARS = b"0123456789,- \t\r\n"
_SENTINEL = "\x00cyborg-int-array\x00"


# A JSON \uD800-\uDFFF escape: the only way a lone surrogate can arrive in valid UTF-8.
_SURROGATE_ESCAPE = re.compile(rb"\\u[dD][89abcdefABCDEF]")


def may_hold_surrogates(payload: bytes) -> bool:
    """Whether decoding ``payload`` may give text with a (lone) UTF-16 surrogate."""
    return _SURROGATE_ESCAPE.search(payload) is not None


def decode_frame(payload: bytes, *, array_topics: frozenset[str] = frozenset()) -> dict[str, Any]:
    """The frame as a dict. Its big integer ``data`` array is an ndarray if the frame's topic is
    in ``array_topics`` (their handlers take arrays), else the same list ``json`` would give."""
    split = _split_int_array(payload)
    if split is None:
        return json.loads(payload)
    head, array = split
    try:
        frame = json.loads(head)
    except ValueError:
        return json.loads(payload)  # the cut was not where a JSON value was
    value = array if isinstance(frame, dict) and frame.get("topic") in array_topics else array.tolist()
    return frame if _put(frame, value) else json.loads(payload)


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


def _split_int_array(payload: bytes) -> tuple[str, np.ndarray] | None:
    """(the frame with its biggest integer ``data`` array replaced by a sentinel, that array)."""
    best: tuple[int, int, np.ndarray] | None = None
    for opening in _data_arrays(payload):
        closing = payload.find(b"]", opening)
        if closing < 0 or (best is not None and closing - opening <= best[1] - best[0]):
            continue
        array = parse_int_array(payload[opening + 1:closing])
        if array is not None:
            best = (opening, closing, array)
    if best is None:
        return None
    opening, closing, array = best
    head = payload[:opening].decode("utf8") + json.dumps(_SENTINEL) + payload[closing + 1:].decode("utf8")
    return head, array


def _data_arrays(payload: bytes) -> Iterator[int]:
    """Offsets of the "[" of every ``"data": [`` key (bytes.find: a regex scan of 32 MB is slower)."""
    at = payload.find(_DATA_KEY)
    while at >= 0:
        match = _THEN_ARRAY.match(payload, at + len(_DATA_KEY))
        if match and payload[at - 1:at] != b"\\":  # not an escaped quote inside a string
            yield match.end() - 1
        at = payload.find(_DATA_KEY, at + 1)


def _put(node: Any, value: Any) -> bool:
    """Put ``value`` where the sentinel is; False if it is nowhere (the cut was not a JSON value)."""
    if isinstance(node, dict):
        for key, item in node.items():
            if isinstance(item, str) and item == _SENTINEL:
                node[key] = value
                return True
            if isinstance(item, dict | list) and _put(item, value):
                return True
    elif isinstance(node, list):
        return any(_put(item, value) for item in node)
    return False
