"""The production topology through nginx over HTTPS: two web processes, two robot links, Celery,
private Redis and PostgreSQL servers that are really stopped and started again.

The tests run in order on one topology; each leaves every process running again.
"""

from __future__ import annotations

import itertools
import os
import subprocess
import time
from pathlib import Path

import pytest
from django.conf import settings
from playwright.sync_api import expect

from tests.browser.support import login
from tests.deploy.topology import PrivatePostgres, Topology
from tests.stack import PYTHON, ROOT
from tests.support_processes import PrivateRedis

pytestmark = [
    pytest.mark.stack,
    pytest.mark.skipif(not settings.REDIS_URL, reason="the production topology runs in the services pass"),
]
_said = itertools.count()


@pytest.fixture(scope="module")
def topology():
    redis = PrivateRedis().start()
    postgres = PrivatePostgres().start()
    topo = Topology(redis_url=redis.url, database_url=postgres.url)
    topo.redis, topo.postgres = redis, postgres
    try:
        topo.up()
        yield topo
    finally:
        try:
            topo.down()
        finally:
            redis.stop()
            postgres.remove()


@pytest.fixture(scope="module")
def dashboard(browser, topology):
    """A viewer's dashboard, through nginx over HTTPS, open for the whole module."""
    context = browser.new_context(ignore_https_errors=True, viewport={"width": 1280, "height": 900})
    page = context.new_page()
    page.set_default_timeout(15_000)
    login(page, topology, "vera")
    expect(page.locator("#link-pill")).to_have_text("robot online")
    yield page
    context.close()


def _say_and_see(topology: Topology, page, *, web: int | None, within_s: float, retry_s: float = 0) -> None:
    """Speak through one web process (or nginx) as an operator; the page must show it within ``within_s``.

    With ``retry_s`` a refusal (503 "try again in a moment" while a service comes back) is retried that long.
    """
    text = f"hello {next(_said)} from {'nginx' if web is None else 'web ' + 'ab'[web]}"
    deadline = time.monotonic() + retry_s
    while True:
        try:
            status, body = topology.fetch("/api/robot/speech/", web=web, method="POST", body={"text": text},
                                          user="otto")
        except OSError as exc:
            if time.monotonic() > deadline:
                raise
            status, body = 0, {"error": str(exc)}
        if status == 200 or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    assert status == 200, (status, body)
    expect(page.locator('[data-field="tts.last"]')).to_have_text(text, timeout=within_s * 1000)


def _pids(topology: Topology) -> dict[str, int]:
    names = ("sim", "link-a", "link-b", "web-a", "web-b", "worker", "beat", "nginx")
    pids = {name: topology.pid(name) for name in names}
    assert all(topology.alive(name) for name in names), topology.logs()
    return pids


def test_the_example_production_environment_passes_check_deploy(tmp_path: Path):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("DJANGO_", "PYTEST_"))}
    for line in (ROOT / "deploy" / "cyborg.env.example").read_text().splitlines():
        if "=" in line and not line.startswith("#"):
            name, value = line.split("=", 1)
            env[name] = value
    env["VAR_DIR"] = str(tmp_path)
    # As on the server (README, "Deploy"): hashed static files are collected before anything else runs.
    subprocess.run([PYTHON, "manage.py", "collectstatic", "--noinput"], cwd=ROOT, env=env, check=True,
                   capture_output=True, timeout=120)
    out = subprocess.run([PYTHON, "manage.py", "check", "--deploy", "--fail-level", "WARNING"], cwd=ROOT, env=env,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "System check identified no issues" in out.stdout


def test_a_page_on_one_web_process_sees_commands_sent_through_either(topology, dashboard):
    assert topology.active_link() in ("link-a", "link-b")
    for web in (0, 1, 0, 1):
        _say_and_see(topology, dashboard, web=web, within_s=1)


def test_killing_a_web_process_moves_its_sockets_to_the_other(topology, dashboard):
    # The page's socket is on one of the two: kill each in turn (bringing the first back in between),
    # so one of the kills certainly drops it. Each time the page must reconnect by itself.
    for victim, survivor in (("web-a", 1), ("web-b", 0)):
        topology.kill(victim)
        _say_and_see(topology, dashboard, web=survivor, within_s=5)
        expect(dashboard.locator("body")).not_to_have_class("socket-down")
        _say_and_see(topology, dashboard, web=None, within_s=2)
        topology.script(f"restart {victim}")
    assert dashboard.url.endswith("/")  # the same page, never reloaded


def test_killing_the_active_link_promotes_the_standby(topology, dashboard):
    active = topology.active_link()
    standby = {"link-a": "link-b", "link-b": "link-a"}[active]
    topology.kill(active)
    topology.wait(lambda: topology.active_link() == standby, timeout=5, what=f"{standby} holding the lease")
    topology.wait(lambda: topology.health().get("connected") is True, timeout=5, what="the robot online again")
    _say_and_see(topology, dashboard, web=None, within_s=3)
    assert not topology.alive(active)
    topology.script(f"restart {active}")
    time.sleep(1)  # the restarted link must stay standby: the lease is held
    assert topology.active_link() == standby


def test_a_redis_restart_is_survived_without_restarting_any_process(topology, dashboard):
    before = _pids(topology)
    topology.redis.stop()
    time.sleep(1)
    topology.redis.start()
    topology.wait(lambda: topology.health().get("connected") is True, timeout=15, what="the robot online again")
    topology.wait(lambda: topology.active_link() is not None, timeout=5, what="a link holding the lease")
    # Redis comes back empty, without the channel layer's group memberships: the page is reloaded.
    dashboard.reload()
    expect(dashboard.locator("#link-pill")).to_have_text("robot online")
    _say_and_see(topology, dashboard, web=None, within_s=3, retry_s=10)
    assert _pids(topology) == before


def test_a_postgresql_restart_is_survived_without_restarting_any_process(topology, dashboard):
    before = _pids(topology)
    topology.postgres.stop()
    time.sleep(1)
    topology.postgres.start()
    # Commands write their audit entry to the database: the first may meet a dead connection.
    topology.wait(lambda: topology.fetch("/api/audit/", user="otto")[0] == 200, timeout=15,
                  what="the API reading the database again", every=0.3)
    _say_and_see(topology, dashboard, web=None, within_s=3, retry_s=10)
    dashboard.reload()
    expect(dashboard.locator("#link-pill")).to_have_text("robot online")
    assert _pids(topology) == before
