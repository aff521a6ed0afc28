"""Durations an admin reads and types as such ("30 d", "12 h", "90 min", "45 s"), stored in seconds."""

from __future__ import annotations

import re
from typing import Any

from django import forms

_UNITS = (("d", 86400), ("h", 3600), ("min", 60), ("s", 1))
_NAMES = {"s": 1, "sec": 1, "second": 1, "seconds": 1, "min": 60, "minute": 60, "minutes": 60,
          "h": 3600, "hour": 3600, "hours": 3600, "d": 86400, "day": 86400, "days": 86400}
_TEXT = re.compile(r"^\s*(\d+(?:[.,]\d+)?)\s*([a-z]*)\s*$", re.I)


def format_duration(seconds: float | None) -> str:
    """The largest unit that states it exactly: 2592000 → "30 d", 5400 → "90 min", 2.5 → "2.5 s"."""
    if seconds is None:
        return ""
    for unit, size in _UNITS[:-1]:
        if seconds >= size and seconds % size == 0:
            return f"{int(seconds // size)} {unit}"
    return f"{seconds:g} s"


def parse_duration(text: str) -> float:
    """ "30 d", "12h", "90 min", "45" (seconds) → seconds; ValueError when it is none of those."""
    match = _TEXT.match(text)
    if match is None or match[2].lower() not in {"", *_NAMES}:
        raise ValueError(text)
    return float(match[1].replace(",", ".")) * _NAMES.get(match[2].lower(), 1)


class DurationInSeconds(forms.Field):
    """A FloatField of seconds shown and typed as a duration."""

    widget = forms.TextInput
    default_error_messages = {"invalid": "A duration such as 30 d, 12 h, 90 min or 45 s."}

    def prepare_value(self, value: Any) -> Any:
        return format_duration(float(value)) if isinstance(value, int | float) else value

    def to_python(self, value: Any) -> float | None:
        if value in self.empty_values:
            return None
        try:
            seconds = parse_duration(str(value))
        except ValueError:
            seconds = 0.0  # refused below, as a duration of nothing is
        if seconds <= 0:
            raise forms.ValidationError(self.error_messages["invalid"], code="invalid")
        return seconds
