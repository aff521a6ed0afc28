"""The one text policy, for everything a person or the robot sends.

Input (``text_problem``/``clean_text``): valid Unicode scalar values only (no lone surrogates),
no control or bidirectional-override characters except newline and tab, a length limit per
field. Output (``scrub``/``scrub_json``): whatever is already stored or arrives from the robot
is made safe to encode (U+FFFD for a lone surrogate), so no reader ever fails on it.
"""

from __future__ import annotations

import math
import re
import unicodedata
from typing import Any

REPLACEMENT = "\ufffd"
_SURROGATE = re.compile("[\ud800-\udfff]")
# Cc (C0/C1 controls but newline and tab), and the bidirectional overrides and isolates that
# make text display in another order than it is stored.
_ALLOWED_CONTROLS = frozenset("\n\t")
_BIDI_CONTROLS = frozenset("\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")


EMPTY = "must not be empty."


class TextRejected(ValueError):
    def __init__(self, field: str, reason: str) -> None:
        super().__init__(f"{field}: {reason}")
        self.field = field
        self.reason = reason


def text_problem(value: str, *, limit: int, multiline: bool = False) -> str | None:
    """Why ``value`` may not be accepted, or None when it may."""
    if len(value) > limit:
        return f"at most {limit} characters (got {len(value)})."
    if _SURROGATE.search(value):
        return "contains an invalid character (a lone UTF-16 surrogate)."
    for char in value:
        if char in _BIDI_CONTROLS:
            return f"contains a text-direction control character (U+{ord(char):04X})."
        if unicodedata.category(char) == "Cc" and not (multiline and char in _ALLOWED_CONTROLS):
            return f"contains a control character (U+{ord(char):04X})."
    return None


def character_problem(value: str, *, multiline: bool = True) -> str | None:
    """``text_problem`` without a length limit: for checking whole request bodies."""
    return text_problem(value, limit=len(value), multiline=multiline)


def clean_text(value: Any, *, field: str, limit: int, multiline: bool = False, allow_empty: bool = False) -> str:
    """``value`` trimmed and checked against the policy, or ``TextRejected`` naming the field."""
    if not isinstance(value, str):
        raise TextRejected(field, "a text value is required.")
    text = value.strip()
    if not text and not allow_empty:
        raise TextRejected(field, EMPTY)
    problem = text_problem(text, limit=limit, multiline=multiline)
    if problem:
        raise TextRejected(field, problem)
    return text


def scrub(text: str) -> str:
    """``text`` with every lone surrogate replaced, so it always encodes as UTF-8."""
    return _SURROGATE.sub(REPLACEMENT, text) if _SURROGATE.search(text) else text


def scrub_json(value: Any) -> Any:
    """A JSON-like value with every string (keys too) scrubbed, and every number that is not finite
    (``1e400`` parses as infinity) as its text, which a JSON column can store; other values unchanged."""
    if isinstance(value, str):
        return scrub(value)
    if isinstance(value, float) and not math.isfinite(value):
        return repr(value)
    if isinstance(value, dict):
        return {scrub_json(k): scrub_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [scrub_json(v) for v in value]
    return value
