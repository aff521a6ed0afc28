"""The Replay and Incidents pages: a banner that says it is a replay, no command controls, and the
incident list with its thumbnail, driver and links; marking and releasing only for those allowed."""

from __future__ import annotations

import json

import pytest

from history.frames import write_frames
from history.incidents import incident_open
from history.models import Incident


@pytest.fixture
def incident(db, settings, tmp_path):
    settings.CAMERA_RECORD_DIR = tmp_path
    write_frames([(1000.0 + i, b"\xff\xd8x\xff\xd9", None) for i in range(0, 120, 5)])
    return incident_open(kind=Incident.Kind.BUMPER, t=1060.0, summary="front bumper pressed")


def _config(body: str) -> dict:
    start = body.index('<script id="replay-config" type="application/json">') + len(
        '<script id="replay-config" type="application/json">')
    return json.loads(body[start:body.index("</script>", start)])


def test_the_replay_page_says_it_is_a_replay_and_has_no_command_controls(client, viewer, incident):
    client.force_login(viewer)
    body = client.get(f"/history/replay/?incident={incident.pk}").content.decode()
    assert 'id="replay-banner"' in body and "Nothing on this page commands the robot" in body
    for control in ("data-command", "data-mode", 'id="drive', "mode-buttons"):
        assert control not in body
    config = _config(body)
    assert (config["start"], config["t"], config["end"]) == (1000.0, 1060.0, 1090.0)
    assert config["incident"] == incident.pk


def test_the_incidents_page_lists_thumbnail_driver_and_links(client, viewer, operator, admin_user, incident):
    client.force_login(viewer)
    body = client.get("/history/incidents/").content.decode()
    assert f'href="/history/replay/?incident={incident.pk}"' in body
    assert f"/api/history/incidents/{incident.pk}/mcap/" in body
    assert "/api/history/frames/" in body and "front bumper pressed" in body
    assert 'id="mark"' not in body and "data-release" not in body
    client.force_login(operator)
    assert 'id="mark"' in client.get("/history/incidents/").content.decode()
    client.force_login(admin_user)
    assert "data-release" in client.get("/history/incidents/").content.decode()


def test_an_audit_row_and_the_history_page_lead_into_replay(client, viewer, db):
    from robot.models import AuditEntry

    entry = AuditEntry.objects.create(username="otto", source="page", action="mode", ok=True)
    client.force_login(viewer)
    assert f'href="/history/replay/?audit={entry.pk}"' in client.get("/activity/").content.decode()
    history = client.get("/history/").content.decode()
    assert 'href="/history/replay/"' in history and 'href="/history/incidents/"' in history
    config = _config(client.get(f"/history/replay/?audit={entry.pk}").content.decode())
    assert config["t"] == entry.created.timestamp() and config["start"] < config["t"] < config["end"]


def test_an_admin_releases_incidents_in_the_admin(client, admin_user, incident):
    client.force_login(admin_user)
    assert client.get("/admin/history/incident/").status_code == 200
    client.post("/admin/history/incident/", {"action": "release", "_selected_action": [incident.pk]})
    incident.refresh_from_db()
    assert not incident.held and incident.released_by == "ada"
