"""Numeric leaves of messages, rolled up at write time into per-second and per-minute min/max buckets.

Plotting a day of a 10 Hz topic from the stored JSON means parsing ~a million rows; the
rollups let the series query read one row per minute (or second) instead. Pure functions:
``history.storage`` writes what ``aggregate`` returns, in the same transaction as the rows.

Not every leaf is rolled up: arrays longer than ``MAX_ARRAY_ITEMS`` (covariances, laser
ranges, images) are skipped, and of a message with more than ``MAX_LEAVES`` numeric leaves
only the first ``MAX_LEAVES`` by path name are kept (by name, not position: PostgreSQL's
jsonb reorders keys, and a rebuild from stored rows must pick the same fields). Fields left
out are still plotted, from the JSON (``history.downsample``'s fallback).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

# Coarsest first. Every bucket width of at least a second on the downsampling ladder is a
# multiple of one of these, so a bucket is the exact sum of whole rollup slots.
LEVELS_S: tuple[int, ...] = (60, 1)
MAX_ARRAY_ITEMS = 9  # small arrays (a quaternion, a few joints) are worth plotting per element
MAX_LEAVES = 32

# (topic, level_s, field, slot) → [t_first, vmin, vmax, vsum, n]; slot = floor(t / level_s)
Key = tuple[str, int, str, int]
Aggregates = dict[Key, list[float]]


def numeric_leaves(msg: Any) -> list[tuple[str, Any]]:
    """(dotted path, value) of the numeric and boolean leaves of a message, in message order."""
    out: list[tuple[str, Any]] = []
    _walk(msg, "", out)
    return out


def _walk(node: Any, prefix: str, out: list[tuple[str, Any]]) -> None:
    # Hot: runs for every recorded message, hence type() tests rather than isinstance on unions.
    if isinstance(node, dict):
        items: Iterable[tuple[Any, Any]] = node.items()
    elif isinstance(node, list) and len(node) <= MAX_ARRAY_ITEMS:
        items = enumerate(node)
    else:
        return
    for key, value in items:
        kind = type(value)
        if kind is float or kind is int or kind is bool:
            out.append((f"{prefix}{key}", value))
        elif kind is dict or kind is list:
            _walk(value, f"{prefix}{key}.", out)


def aggregate(messages: Iterable[tuple[str, float, Any]], levels: Iterable[int] = LEVELS_S) -> Aggregates:
    """Min/max/sum/count and first time per (topic, level, field, slot) of (topic, t, message) triples."""
    seconds: dict[tuple[str, str, int], list[float]] = {}
    for topic, t, msg in messages:
        slot = math.floor(t)
        leaves = numeric_leaves(msg)
        if len(leaves) > MAX_LEAVES:
            leaves = sorted(leaves)[:MAX_LEAVES]
        for path, raw in leaves:
            try:
                value = float(raw)
            except OverflowError:  # a JSON integer beyond float range
                continue
            if value - value != 0:  # NaN or infinite
                continue
            key = (topic, path, slot)
            agg = seconds.get(key)
            if agg is None:
                seconds[key] = [t, value, value, value, 1]
                continue
            if t < agg[0]:
                agg[0] = t
            if value < agg[1]:
                agg[1] = value
            elif value > agg[2]:
                agg[2] = value
            agg[3] += value
            agg[4] += 1
    out: Aggregates = {}
    for level in levels:
        for (topic, path, second), (t, vmin, vmax, vsum, n) in seconds.items():
            into = out.setdefault((topic, level, path, second // level), [math.inf, math.inf, -math.inf, 0.0, 0])
            into[:] = min(into[0], t), min(into[1], vmin), max(into[2], vmax), into[3] + vsum, into[4] + n
    return out


def level_for(width_ms: int) -> int | None:
    """The coarsest rollup level whose slots tile buckets of ``width_ms``; None below a second."""
    return next((level for level in LEVELS_S if width_ms % (level * 1000) == 0), None)
