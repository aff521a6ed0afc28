"""The Alerts page: the history of alerts, and your choice of which reach you beyond the tab."""

from __future__ import annotations

from django.http import HttpRequest, HttpResponse
from django.templatetags.static import static
from django.urls import reverse

from cyborg_site.rendering import render_safe
from robot.alerts.models import KINDS, Alert
from robot.alerts.selectors import alerts_history

HISTORY_ROWS = 100


def alerts_page(request: HttpRequest) -> HttpResponse:
    kind = request.GET.get("kind", "")
    return render_safe(request, "dashboard/alerts.html", {
        "history": alerts_history(limit=HISTORY_ROWS, kind=kind if kind in KINDS else ""),
        "kinds": KINDS,
        "kind": kind,
        "severities": Alert.Severity.values,
        "alerts_config": {
            "choice_url": reverse("api-alert-choice"),
            "push_url": reverse("api-push-subscriptions"),
            "worker_url": static("js/push-sw.js"),
        },
    })
