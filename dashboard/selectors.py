"""Read-only data the dashboard pages need."""

from __future__ import annotations

from typing import Any

from django.conf import settings
from django.templatetags.static import static

from dashboard.routing import AUDIO_SOCKET_PATH
from robot import interface as ri
from robot.live.keys import HOME_KEYS


def audio_config() -> dict[str, str]:
    """What the audio card (static/js/audio.js) needs, on every page that shows it."""
    return {"audio_socket": AUDIO_SOCKET_PATH, "audio_worklet": static("js/audio-capture.js")}


def dashboard_context() -> dict[str, Any]:
    return {
        "live_config": {
            "keys": list(HOME_KEYS),
            "stale_after_s": settings.STALE_AFTER_S,
            "battery_low_percent": settings.BATTERY_LOW_PERCENT,
            "log_levels": ri.LOG_LEVELS,
            "recharge_states": ri.RECHARGE_STATES,
            "rosbridge_url": settings.ROSBRIDGE_URL,
            **audio_config(),
        },
    }
