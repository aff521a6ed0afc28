"""The Connect a ROS tool page: a single-use ticket for Foxglove, Lichtblick, roslibjs or roslibpy,
and a roslibjs check that the front door answers from this very browser."""

from __future__ import annotations

from django.conf import settings
from django.http import HttpRequest, HttpResponse
from django.shortcuts import render
from django.urls import reverse

from robot import interface as ri


def frontdoor_page(request: HttpRequest) -> HttpResponse:
    config = {
        "urls": {"ticket": reverse("api-frontdoor-ticket")},
        "watch": {"name": ri.topic("battery_soc").name, "type": ri.topic("battery_soc").type},
    }
    return render(request, "dashboard/frontdoor.html", {"frontdoor_config": config,
                                                        "ticket_s": settings.FRONTDOOR_TICKET_S})
