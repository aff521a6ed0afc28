"""Pages that show text from the robot or from stored rows render whatever that text holds."""

from __future__ import annotations

from typing import Any

from django.http import HttpRequest, HttpResponse
from django.template.loader import render_to_string

from cyborg_site.text import scrub


def render_safe(request: HttpRequest, template: str, context: dict[str, Any]) -> HttpResponse:
    """``render``, with a lone surrogate anywhere in the page shown as U+FFFD instead of failing to encode."""
    return HttpResponse(scrub(render_to_string(template, context, request)))
