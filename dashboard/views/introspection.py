"""The state machine page (the robot's SMACH graph, live) and the diagnostics page."""

from __future__ import annotations

from django.conf import settings
from django.http import HttpRequest, HttpResponse
from django.shortcuts import render
from django.templatetags.static import static

from cyborg_site.csp import csp_extend
from robot import interface as ri
from robot.live.keys import DIAGNOSTICS_PAGE_KEYS, STATEMACHINE_KEYS


@csp_extend(script_src=("'wasm-unsafe-eval'",))  # Graphviz is WebAssembly
def statemachine(request: HttpRequest) -> HttpResponse:
    config = {
        "keys": list(STATEMACHINE_KEYS),
        # Graphviz (compiled to WebAssembly) lays the graph out in the browser: loaded on this page only.
        "viz_url": static("vendor/viz/viz.js"),
        "stale_after_s": settings.STALE_AFTER_S,
    }
    return render(request, "dashboard/statemachine.html", {"smach_config": config})


def diagnostics(request: HttpRequest) -> HttpResponse:
    config = {
        "keys": list(DIAGNOSTICS_PAGE_KEYS),
        "levels": ri.DIAGNOSTIC_LEVELS,
        "stale_after_s": settings.STALE_AFTER_S,
    }
    return render(request, "dashboard/diagnostics.html", {"diagnostics_config": config})
