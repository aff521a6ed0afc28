"""The manual control page: camera, keyboard and joystick driving, speed limits, e-stop."""

from __future__ import annotations

from django.conf import settings
from django.http import HttpRequest, HttpResponse
from django.shortcuts import render
from django.urls import reverse

from dashboard.routing import TELEOP_SOCKET_PATH
from dashboard.selectors import audio_config
from robot.live.keys import DRIVE_KEYS

# Without a new camera frame for this long the picture is shown as unavailable.
CAMERA_STALE_S = 2.0


def drive_config() -> dict[str, object]:
    return {
        "max_linear": settings.TELEOP_MAX_LINEAR,
        "max_angular": settings.TELEOP_MAX_ANGULAR,
        "rate_hz": settings.TELEOP_RATE_HZ,
        "deadman_s": settings.TELEOP_DEADMAN_S,
        "stream_url": reverse("dashboard:video-stream"),
        "snapshot_url": reverse("dashboard:video-snapshot"),
        "teleop_socket": TELEOP_SOCKET_PATH,
        **audio_config(),
        "camera_stale_s": CAMERA_STALE_S,
        "keys": list(DRIVE_KEYS),
    }


def drive(request: HttpRequest) -> HttpResponse:
    return render(request, "dashboard/drive.html", {"drive_config": drive_config()})
