"""APIs speak UTC whatever the site's display time zone is."""

from __future__ import annotations

from datetime import UTC, datetime

import pytest

from robot.models import AuditEntry

pytestmark = pytest.mark.django_db


def test_the_audit_api_gives_times_in_utc(viewer_api, settings):
    assert settings.TIME_ZONE != "UTC"  # the pages show the site's zone; the API must not
    entry = AuditEntry.objects.create(username="otto", source="api", action="mode", params={}, ok=True, outcome="done")
    created = viewer_api.get("/api/audit/").json()["results"][0]["created"]
    assert created.endswith("Z")
    assert datetime.fromisoformat(created) == entry.created.astimezone(UTC)
