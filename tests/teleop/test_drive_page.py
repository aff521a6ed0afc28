"""The manual control page: driving controls for operators, a watch-only view for viewers."""

import json

from django.contrib.staticfiles import finders


def test_it_gives_operators_the_driving_controls(client, operator, settings):
    client.force_login(operator)
    response = client.get("/drive/")
    assert response.status_code == 200
    body = response.content.decode()
    for marker in ('id="stick"', 'id="max-linear"', 'id="lock-acquire"', 'id="camera-img"', 'data-commands="mode"',
                   'class="speech-form"', "js/drive.js"):
        assert marker in body, marker
    assert 'id="lock-takeover"' not in body  # admins only
    config = response.context["drive_config"]
    assert config["max_linear"] == settings.TELEOP_MAX_LINEAR and config["stream_url"] == "/video/stream"
    assert json.dumps(config["stream_url"]) in body
    assert settings.VIDEO_URL not in body  # the browser never learns the video server's address


def test_it_offers_takeover_to_admins(client, admin_user):
    client.force_login(admin_user)
    assert 'id="lock-takeover"' in client.get("/drive/").content.decode()


def test_it_shows_viewers_the_camera_and_readouts_without_controls(client, viewer):
    client.force_login(viewer)
    body = client.get("/drive/").content.decode()
    assert 'id="camera-img"' in body and 'id="odom-vel"' in body
    assert 'id="stick"' not in body and 'id="lock-acquire"' not in body
    assert 'data-can-drive="false"' in body


def test_it_serves_the_vendored_joystick_with_its_licence():
    assert finders.find("vendor/nipplejs/index.mjs")
    assert "MIT" in open(finders.find("vendor/nipplejs/LICENSE")).read()
