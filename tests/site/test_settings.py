"""Settings come from the environment; the embedded default and the Redis wiring differ only there:
the same channel layer either way, on the process's private server or on ``REDIS_URL``."""

import runpy
from pathlib import Path

import pytest

from cyborg_site.env import EnvError

SETTINGS = Path(__file__).resolve().parents[2] / "cyborg_site" / "settings.py"


def load(monkeypatch, **env):
    for name in ("REDIS_URL", "DATABASE_URL", "DEBUG", "ROSBRIDGE_URL", "ROBOT_NAME_OVERRIDES", "MODE_COMMANDER"):
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    return runpy.run_path(str(SETTINGS))


def test_it_defaults_to_the_embedded_setup(monkeypatch, tmp_path):
    s = load(monkeypatch, VAR_DIR=str(tmp_path))
    assert s["EMBEDDED"] is True
    layer = s["CHANNEL_LAYERS"]["default"]
    assert layer["BACKEND"] == "robot.live.channel_layer.RedisChannelLayer"
    assert [h["address"] for h in layer["CONFIG"]["hosts"]] == [s["REDIS_URL"]]
    assert s["REDIS_URL"].startswith("unix://") and s["REDIS_URL"].endswith("/valkey.sock")
    assert load(monkeypatch, VAR_DIR=str(tmp_path))["REDIS_URL"] != s["REDIS_URL"], "a private server each"
    assert s["DATABASES"]["default"]["ENGINE"] == "django.db.backends.sqlite3"
    assert str(s["DATABASES"]["default"]["NAME"]).startswith(str(tmp_path))
    assert s["ROSBRIDGE_URL"] == "ws://127.0.0.1:9090"
    assert s["VIDEO_URL"] == "http://127.0.0.1:8080"
    assert s["CELERY_BROKER_URL"] == "memory://"
    assert (tmp_path / "secret_key").exists(), "a local secret key is generated once and kept"
    assert (tmp_path / "secret_key").stat().st_mode & 0o777 == 0o600, "readable by its owner only"
    assert load(monkeypatch, VAR_DIR=str(tmp_path))["SECRET_KEY"] == s["SECRET_KEY"]


def test_it_wires_redis_and_postgres_from_urls(monkeypatch, tmp_path):
    s = load(
        monkeypatch, VAR_DIR=str(tmp_path), REDIS_URL="redis://127.0.0.1:6379/3",
        DATABASE_URL="postgres://postgres@127.0.0.1:5432/test", ROSBRIDGE_URL="wss://cyborg.example:9090",
    )
    assert s["EMBEDDED"] is False
    layer = s["CHANNEL_LAYERS"]["default"]
    assert layer["BACKEND"] == "robot.live.channel_layer.RedisChannelLayer"
    assert [h["address"] for h in layer["CONFIG"]["hosts"]] == ["redis://127.0.0.1:6379/3"]
    # Longer than the layer's blocking receive (5 s), or a quiet channel's receive() raises.
    assert layer["CONFIG"]["hosts"][0]["socket_timeout"] > 5
    assert s["CELERY_BROKER_URL"] == "redis://127.0.0.1:6379/3"
    assert s["DATABASES"]["default"]["ENGINE"] == "django.db.backends.postgresql"
    assert s["ROSBRIDGE_URL"] == "wss://cyborg.example:9090"


def test_it_reads_topic_name_overrides(monkeypatch, tmp_path):
    s = load(monkeypatch, VAR_DIR=str(tmp_path), ROBOT_NAME_OVERRIDES='{"topics": {"cmd_vel": "/RosAria/cmd_vel"}}')
    assert s["ROBOT_TOPICS"] == {"cmd_vel": "/RosAria/cmd_vel"}


@pytest.mark.parametrize(
    ("name", "value"),
    [("DEBUG", "maybe"), ("ROBOT_NAME_OVERRIDES", "[1, 2]"), ("STALE_AFTER_S", "soon"), ("MODE_COMMANDER", "ros")],
)
def test_it_refuses_bad_values_loudly(monkeypatch, tmp_path, name, value):
    with pytest.raises(EnvError, match=name):
        load(monkeypatch, VAR_DIR=str(tmp_path), **{name: value})
