"""The Topics page: every topic the robot has, and any one of them live (viewers may watch)."""

from __future__ import annotations

from django.conf import settings
from django.http import HttpRequest, HttpResponse
from django.shortcuts import render
from django.urls import reverse

from history.models import Mode
from history.plotunits import unit_rules

# A person reads a message view at most this often; the plot takes every update the server sends.
VIEW_RATE_HZ = 4.0


def topics_page(request: HttpRequest) -> HttpResponse:
    config = {
        "view_rate_hz": VIEW_RATE_HZ,
        "echo_rate_hz": settings.TOPICS_ECHO_MAX_HZ,
        "record_mode": Mode.EVERY,
        "units": unit_rules(),
        "urls": {
            "topics": reverse("api-topics"),
            "rate": reverse("api-topics-rate"),
            "policies": reverse("history-topics"),
            "history": reverse("history:index"),
        },
    }
    return render(request, "dashboard/topics.html", {"topics_config": config})
