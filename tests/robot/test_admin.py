"""The admin: named places with coordinates to the millimetre, and times in 24 hours on every page."""

from __future__ import annotations

from datetime import UTC, datetime

import pytest

from robot.models import AuditEntry, Location

pytestmark = pytest.mark.django_db


def test_it_shows_location_coordinates_to_three_decimals(admin_logged_in):
    place = Location.objects.create(name="reception", x=1.2345678901234567, y=-0.30000000000000004, yaw=0.5)
    listing = admin_logged_in.get("/admin/robot/location/").content.decode()
    assert "1.235" in listing and "-0.300" in listing and "1.2345678" not in listing
    form = admin_logged_in.get(f"/admin/robot/location/{place.pk}/change/").content.decode()
    assert 'value="1.235"' in form and 'value="-0.3"' in form and "1.2345678" not in form


def test_it_shows_times_in_24_hours(admin_logged_in, settings):
    settings.TIME_ZONE = "UTC"
    entry = AuditEntry.objects.create(username="otto", source="api", action="estop", ok=True, outcome="ok")
    AuditEntry.objects.filter(pk=entry.pk).update(created=datetime(2026, 11, 28, 16, 3, 12, tzinfo=UTC))
    listing = admin_logged_in.get("/admin/robot/auditentry/").content.decode()
    assert "16:03" in listing and "p.m." not in listing, listing[listing.find("result_list"):][:2000]
