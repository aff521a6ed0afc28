"""A message cut down to what a page can show: long arrays and strings summarised, never sent whole.

A laser scan's 541 ranges, a camera frame's base64 bytes or a map's millions of cells would cost
the browser (and every socket on the way) far more than a person can read. ``summarise`` keeps
the message's shape and replaces each long array with ``{"_truncated": "array", "length": n,
"items": [the first few]}`` and each long string with ``{"_truncated": "string", "length": n,
"text": the start}``, so the page can still show, expand and plot what it has.
"""

from __future__ import annotations

from typing import Any

import numpy as np

MAX_ITEMS = 16  # arrays longer than this keep their first ``HEAD_ITEMS``
HEAD_ITEMS = 8
MAX_CHARS = 512  # strings longer than this keep their first ``HEAD_CHARS``
HEAD_CHARS = 200
MAX_DEPTH = 24  # deeper than any ROS message; cut rather than recurse without end

TRUNCATED = "_truncated"


def summarise(value: Any, depth: int = 0) -> Any:
    """``value`` with every array longer than ``MAX_ITEMS`` and every string longer than
    ``MAX_CHARS`` summarised (recursively); small messages come back equal to themselves."""
    if isinstance(value, dict):
        if depth >= MAX_DEPTH:
            return {TRUNCATED: "object", "length": len(value)}
        return {k: summarise(v, depth + 1) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        value = value.ravel()
        return _array(len(value), value[:HEAD_ITEMS].tolist(), depth) if value.size > MAX_ITEMS else value.tolist()
    if isinstance(value, list | tuple):
        if depth >= MAX_DEPTH:
            return {TRUNCATED: "array", "length": len(value), "items": []}
        if len(value) > MAX_ITEMS:
            return _array(len(value), value[:HEAD_ITEMS], depth)
        return [summarise(v, depth + 1) for v in value]
    if isinstance(value, str) and len(value) > MAX_CHARS:
        return {TRUNCATED: "string", "length": len(value), "text": value[:HEAD_CHARS]}
    if isinstance(value, np.generic):
        return value.item()
    return value


def _array(length: int, head: Any, depth: int) -> dict[str, Any]:
    return {TRUNCATED: "array", "length": length, "items": [summarise(v, depth + 1) for v in head]}
