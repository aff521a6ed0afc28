"""Headings are degrees wherever a person reads or types them; the robot and the API keep radians."""

from __future__ import annotations

import math

import pytest
from django.test import Client

from robot.models import Location

pytestmark = pytest.mark.django_db(transaction=True)


def test_the_admin_takes_and_shows_headings_in_degrees(admin_user):
    client = Client()
    client.force_login(admin_user)
    res = client.post("/admin/robot/location/add/", {
        "name": "kitchen", "map_name": "", "x": "1.5", "y": "-2", "heading_deg": "90", "threshold": "0.5",
        "description": ""})
    assert res.status_code == 302, res.content.decode()[:2000]
    kitchen = Location.objects.get(name="kitchen")
    assert kitchen.yaw == pytest.approx(math.pi / 2)

    form = client.get(f"/admin/robot/location/{kitchen.pk}/change/").content.decode()
    assert 'name="heading_deg"' in form and 'value="90.0"' in form and "Heading (°)" in form
    assert 'name="yaw"' not in form
    listing = client.get("/admin/robot/location/").content.decode()
    assert "Heading (°)" in listing and ">90<" in listing
