"""Data the command partials need, so any page can include them without view changes."""

from __future__ import annotations

import json
from typing import Any

from django import template
from django.conf import settings

from robot import interface as ri
from robot.commands.validation import EVENT_MAX, SPEECH_MAX
from robot.models import DomeMode, EmotionPreset, SoundClip

register = template.Library()

MODE_HELP = {
    ri.Mode.BEHAVIOUR: "Autonomous: emotion system on, the robot chooses what to do.",
    ri.Mode.DEMO: "A timed demonstration; emotion system off; ends by itself.",
    ri.Mode.MANUAL: "For driving and commanding by hand; emotion system off.",
    ri.Mode.STOP: "Suspend: emotion system off, the state machine waits.",
}


@register.simple_tag
def command_presets() -> dict[str, Any]:
    return {
        "emotions": list(EmotionPreset.objects.all()),
        "clips": list(SoundClip.objects.all()),
        "dome_modes": list(DomeMode.objects.all()),
        "speech_max": SPEECH_MAX,
        "event_max": EVENT_MAX,
    }


@register.simple_tag
def mode_buttons() -> list[dict[str, str]]:
    return [{"name": m.short, "label": m.short.capitalize(), "help": MODE_HELP[m],
             "target": ri.MODE_TARGET_STATE[m].value} for m in ri.Mode]


@register.simple_tag
def commands_config() -> str:
    """JSON for the mode commander's ``data-config`` attribute (auto-escaped there)."""
    outside = sorted(s.value for s in ri.State if s not in (ri.State.BEHAVIOUR, ri.State.IDLE))
    return json.dumps({
        "grace_s": settings.MODE_MISMATCH_GRACE_S,
        "strategy": settings.MODE_COMMANDER,
        "targets": {m.short: ri.MODE_TARGET_STATE[m].value for m in ri.Mode},
        "outside_behaviour": outside,
        "speech_max": SPEECH_MAX,
    })
