"""Input checks shared by every command source (page, API, websocket).

Each ``clean_*`` returns the value to send or raises ``InvalidCommand`` naming the field.
Preset lookups hit the database, so they are async.
"""

from __future__ import annotations

import re
from functools import partial
from typing import Any

from django.db.models import Model

from cyborg_site.text import EMPTY, TextRejected, clean_text
from robot import interface as ri
from robot.commands.pipeline import InvalidCommand
from robot.models import DomeMode, EmotionPreset, SoundClip

EVENT_MAX = 64
SPEECH_MAX = 500
NAME_MAX = 64  # preset names (emotion, sound clip, dome mode), as in the models
_EVENT_RE = re.compile(r"^[A-Za-z0-9_]+$")
MODE_NAMES = tuple(m.short for m in ri.Mode)


def _text(value: Any, field: str, *, limit: int, empty: str = "", multiline: bool = False) -> str:
    """Text through the site's text policy; an empty value is refused with ``empty`` when given."""
    try:
        return clean_text(value, field=field, limit=limit, multiline=multiline, allow_empty=not empty)
    except TextRejected as exc:
        reason = empty if exc.reason == EMPTY else exc.reason
        raise InvalidCommand(f"{field}: {reason}", field=field) from None


def clean_event(value: Any) -> str:
    event = _text(value, "event", limit=EVENT_MAX, empty="name an event (e.g. aborted).")
    if not _EVENT_RE.match(event):
        raise InvalidCommand("event: use letters, digits and '_' only.", field="event")
    return event


def clean_speech(value: Any) -> str:
    return _text(value, "text", limit=SPEECH_MAX, empty="say something (the text is empty).", multiline=True)


def clean_bool(value: Any, field: str) -> bool:
    if not isinstance(value, bool):
        raise InvalidCommand(f"{field}: true or false is required.", field=field)
    return value


def clean_mode(value: Any) -> ri.Mode:
    name = _text(value, "mode", limit=NAME_MAX)
    try:
        return ri.Mode.from_short(name)
    except ValueError:
        raise InvalidCommand(f"mode: one of {', '.join(MODE_NAMES)}.", field="mode") from None


def _preset(model: type[Model], value: Any, field: str, what: str) -> str:
    name = _text(value, field, limit=NAME_MAX)
    if not name or not model._default_manager.filter(name=name).exists():
        names = list(model._default_manager.values_list("name", flat=True))
        raise InvalidCommand(f"{field}: unknown {what} {name!r}; known: {', '.join(names) or 'none'}.", field=field)
    return name


# The presets a command names: each must exist.
clean_emotion = partial(_preset, EmotionPreset, field="emotion", what="emotion")
clean_clip = partial(_preset, SoundClip, field="clip", what="sound clip")
clean_dome_mode = partial(_preset, DomeMode, field="mode", what="dome mode")
