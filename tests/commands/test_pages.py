"""The command controls on the dashboard and the Activity page, server-rendered per role."""

from __future__ import annotations

import re

import pytest

from robot.models import AuditEntry, EmotionPreset

pytestmark = pytest.mark.django_db

MODE_BUTTON = re.compile(r'<button[^>]*data-mode="(\w+)"[^>]*>')


def _mode_buttons(html: str) -> dict[str, bool]:
    """mode -> enabled"""
    return {m.group(1): " disabled" not in m.group(0) for m in MODE_BUTTON.finditer(html)}


def test_it_gives_operators_working_controls_with_the_presets(client, operator):
    client.force_login(operator)
    html = client.get("/").content.decode()
    assert _mode_buttons(html) == {"behaviour": True, "demo": True, "manual": True, "stop": True}
    for preset in EmotionPreset.objects.all():
        assert f'<option value="{preset.name}"' in html
    assert '<option value="hello_there"' in html and '<option value="rainbow"' in html
    assert 'maxlength="500"' in html
    assert "can watch but not command" not in html


def test_it_disables_every_control_for_viewers(client, viewer):
    client.force_login(viewer)
    html = client.get("/").content.decode()
    assert _mode_buttons(html) == {"behaviour": False, "demo": False, "manual": False, "stop": False}
    command_cards = html.split('id="card-mode"')[1].split('id="log-card"')[0]
    commands = re.findall(r"<(?:button|select|input|textarea)\b[^>]*>", command_cards)
    assert commands and all(" disabled" in tag for tag in commands), [t for t in commands if " disabled" not in t]
    assert "can watch but not command" in html


def test_it_reads_presets_edited_in_the_admin(client, operator):
    EmotionPreset.objects.create(name="mischievous", pleasure=0.3, arousal=0.6, dominance=0.4)
    client.force_login(operator)
    assert '<option value="mischievous"' in client.get("/").content.decode()


def test_it_lists_activity_newest_first_and_filters(client, viewer):
    AuditEntry.objects.create(username="otto", source="api", action="mode", params={"mode": "demo"}, ok=True,
                              outcome="Demo mode: sent aborted")
    AuditEntry.objects.create(username="vera", source="page", action="speech", params={"text": "hi"}, ok=False,
                              outcome="Your role may not command the robot", error_code="forbidden")
    client.force_login(viewer)
    html = client.get("/activity/").content.decode()
    assert html.index("Your role may not command") < html.index("Demo mode: sent aborted")
    failed = client.get("/activity/?outcome=failed").content.decode()
    assert "forbidden" in failed and "Demo mode: sent aborted" not in failed
    by_otto = client.get("/activity/?user=otto&action=mode").content.decode()
    assert "mode=demo" in by_otto and "text=hi" not in by_otto


def test_it_paginates_activity(client, operator):
    AuditEntry.objects.bulk_create([AuditEntry(username="otto", source="api", action="event", ok=True,
                                               outcome=f"entry {i}") for i in range(60)])
    client.force_login(operator)
    first = client.get("/activity/").content.decode()
    assert "page 1 of 2" in first and "60 entries" in first
    assert "Older" in first
    second = client.get("/activity/?page=2").content.decode()
    assert second.count('class="row-ok"') == 10


def test_it_sends_anonymous_visitors_of_activity_to_login(client):
    res = client.get("/activity/")
    assert res.status_code == 302 and "/accounts/login/" in res["Location"]
