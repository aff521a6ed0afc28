"""The Activity page: every command sent to the robot, newest first, filterable."""

from __future__ import annotations

from urllib.parse import urlencode

from django.core.paginator import Paginator
from django.http import HttpRequest, HttpResponse

from cyborg_site.rendering import render_safe
from robot.commands.selectors import AUDIT_FILTERS, audit_entries
from robot.models import AuditEntry

PAGE_SIZE = 50


def activity(request: HttpRequest) -> HttpResponse:
    filters = {name: request.GET.get(name, "").strip() for name in AUDIT_FILTERS}
    page = Paginator(audit_entries(filters), PAGE_SIZE).get_page(request.GET.get("page"))
    query = urlencode({k: v for k, v in filters.items() if v})
    return render_safe(request, "dashboard/activity.html", {
        "page_obj": page,
        "filters": filters,
        "query": query,
        "sources": AuditEntry.Source.values,
        "actions": AuditEntry.objects.order_by("action").values_list("action", flat=True).distinct(),
        "users": AuditEntry.objects.exclude(username="").order_by("username")
                                   .values_list("username", flat=True).distinct(),
    })
