"""The one text policy, for everything a person or the robot sends.

Input (``text_problem``/``clean_text``): valid Unicode scalar values only (no lone surrogates),
nothing invisible or unassigned (controls but newline and tab, format characters such as the
bidirectional overrides, zero-width joiners and tag characters, line and paragraph separators,
private-use characters, unassigned code points and noncharacters), a length limit per field:
what reaches the robot's speech is what a person can see in the field. Output
(``scrub``/``scrub_json``): whatever is already stored or arrives from the robot is made safe to
encode (U+FFFD for a lone surrogate), so no reader ever fails on it.
"""

from __future__ import annotations

import math
import re
import unicodedata
from typing import Any

REPLACEMENT = "\ufffd"
_SURROGATE = re.compile("[\ud800-\udfff]")
_ALLOWED_CONTROLS = frozenset("\n\t")
# The bidirectional overrides and isolates, which make text display in another order than it is stored.
_BIDI_CONTROLS = frozenset("\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")
# Unicode general categories refused, with what to call them. An emoji joined with U+200D (a family,
# a profession) and a subdivision flag (tag characters) are refused with them: the joiner and the tags
# pass invisibly into the robot's speech. Cn is as of this Python's Unicode version.
_REFUSED_CATEGORIES = {
    "Cc": "a control character",
    "Cf": "an invisible formatting character",
    "Zl": "a line separator",
    "Zp": "a paragraph separator",
    "Co": "a private-use character",
    "Cn": "an unassigned code point or noncharacter",
}
ALLOWED = "letters, marks, digits, punctuation, symbols (emoji too)"


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
        refused = "a text-direction control character" if char in _BIDI_CONTROLS \
            else _REFUSED_CATEGORIES.get(unicodedata.category(char))
        if refused and not (multiline and char in _ALLOWED_CONTROLS):
            name = unicodedata.name(char, "")
            allowed = f"{ALLOWED}, spaces, newlines and tabs" if multiline else f"{ALLOWED} and spaces"
            return f"contains {refused} (U+{ord(char):04X}{' ' + name if name else ''}): only {allowed} are accepted."
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
