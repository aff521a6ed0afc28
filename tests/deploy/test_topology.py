"""The production topology through nginx over HTTPS: two web processes, two robot links, Celery,
private Redis and PostgreSQL servers that are really stopped and started again.

The tests run in order on one topology; each leaves every process running again.
"""

from __future__ import annotations

import concurrent.futures
import itertools
import json
import os
import secrets
import subprocess
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path

import pytest
from django.conf import settings
from playwright.sync_api import expect

from robot import interface as ri
from tests.browser.support import login
from tests.deploy.topology import _TLS, Topology, on_private_services
from tests.stack import PASSWORD, PYTHON, ROOT

pytestmark = [
    pytest.mark.stack,
    pytest.mark.skipif(settings.EMBEDDED, reason="the production topology runs in the services pass"),
]
_said = itertools.count()
RATE_HZ = 10.0  # the simulator's /odom, recorded every message
ODOM = ri.topic("odom").name
SPEECH = ri.topic("text_to_speech").name
# A handover takes well under a second (bench/failover.py); the bound leaves room for a loaded machine.
UNWATCHED_S = 5.0
LINK_WATCH_EVERY_S = 0.5


@pytest.fixture(scope="module")
def topology():
    # The rolling restart sends a command every 0.1 s: more than the per-user throttle allows.
    # The link_down alert 3 s after the last link's heartbeat, checked twice a second.
    with on_private_services(env={"COMMAND_THROTTLE_RATE": "2000/min", "LINK_DOWN_ALERT_S": "3",
                                  "LINK_WATCH_EVERY_S": str(LINK_WATCH_EVERY_S)}) as topo:
        topo.env["STACK_SIM_ARGS"] = f"--pose-rate {RATE_HZ:g}"
        topo.up()
        topo.record_every(ODOM, ri.topic("odom").type)
        yield topo


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
    dead = [name for name in names if not topology.alive(name)]
    assert not dead, "\n".join(f"{name} is dead; its log ends:\n{topology.log(name)[-8000:]}" for name in dead)
    return pids


def test_the_example_production_environment_passes_check_deploy_once_its_secret_key_is_set(tmp_path: Path):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("DJANGO_", "PYTEST_"))}
    for line in (ROOT / "deploy" / "cyborg.env.example").read_text().splitlines():
        if "=" in line and not line.startswith("#"):
            name, value = line.split("=", 1)
            env[name] = value
    env["VAR_DIR"] = str(tmp_path)

    def manage(*args: str, secret_key: str) -> subprocess.CompletedProcess:
        return subprocess.run([PYTHON, "manage.py", *args], cwd=ROOT, env={**env, "SECRET_KEY": secret_key},
                              capture_output=True, text=True, timeout=120)

    # As on the server (README, "Deploy"): hashed static files are collected before anything else runs.
    assert manage("collectstatic", "--noinput", secret_key=secrets.token_urlsafe(50)).returncode == 0
    for check in (("check",), ("check", "--deploy")):
        out = manage(*check, secret_key=env["SECRET_KEY"])  # the example's CHANGE-ME
        assert out.returncode != 0 and "cyborg_site.E001" in out.stderr, out.stdout + out.stderr
    out = manage("check", "--deploy", "--fail-level", "WARNING", secret_key=secrets.token_urlsafe(50))
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


def _missing(seqs: list[int]) -> int:
    """Messages absent from a run of header.seq numbers (the simulator numbers every /odom it publishes)."""
    return sum(b - a - 1 for a, b in itertools.pairwise(seqs) if b > a)


def _recorded(topology: Topology) -> list[int]:
    return topology.recorded_seqs(topology.postgres.url, ODOM)


def _history_lost(topology: Topology) -> int | None:
    return topology.health(details=True).get("history_lost_in_handovers", {}).get(ODOM)


def test_killing_the_active_link_promotes_the_standby_and_counts_the_history_lost(topology, dashboard):
    topology.wait(lambda: len(_recorded(topology)) > 2 * RATE_HZ, timeout=20, what="/odom being recorded")
    assert _missing(_recorded(topology)) == 0  # nothing lost while one link runs
    active = topology.active_link()
    standby = {"link-a": "link-b", "link-b": "link-a"}[active]
    killed, killed_wall = time.monotonic(), time.time()
    topology.kill(active)
    topology.wait(lambda: topology.active_link() == standby and topology.store_entry("odom").get("t", 0) > killed_wall,
                  timeout=10, what=f"{standby} holding the lease with /odom flowing", every=0.02)
    failover_s = time.monotonic() - killed
    topology.wait(lambda: topology.health().get("connected") is True, timeout=5, what="the robot online again")
    _say_and_see(topology, dashboard, web=None, within_s=3)
    assert not topology.alive(active)

    # Messages the dead link took but never wrote, and those before the standby's first: lost, counted
    # by the new recorder exactly as the robot's own numbering says, and no more than the failover lasted.
    topology.wait(lambda: _history_lost(topology) is not None and len(_recorded(topology)) > 0, timeout=10,
                  what="the new recorder's count in /healthz")
    lost = _missing(_recorded(topology))
    assert _history_lost(topology) == lost, (_history_lost(topology), lost)
    flush_s = 1.0  # what the dead link had taken since its last write: HISTORY_FLUSH_S (0.5 s), doubled for load
    assert lost <= (failover_s + flush_s) * RATE_HZ + 1, (lost, failover_s)

    topology.script(f"restart {active}")
    topology.wait(lambda: topology.started(active) >= 1, timeout=60, what=f"{active} back as the standby")
    time.sleep(1)  # the restarted link must stay standby: the lease is held
    assert topology.active_link() == standby


def test_a_rolling_restart_commands_the_robot_once_and_keeps_watching_it(topology, dashboard):
    """SIGTERM each link in turn (the active one hands over) and each web process, while an operator keeps
    sending commands through nginx: the robot gets each exactly once, and its state never stops flowing."""
    topology.wait(lambda: len(_recorded(topology)) > RATE_HZ, timeout=20, what="/odom being recorded")
    recorded_before = max(_recorded(topology))
    sent: dict[str, int] = {}  # text -> HTTP status (0: no answer)
    why: dict[str, str] = {}
    began = time.time()
    stalest = [0.0]
    done = threading.Event()

    def operator() -> None:
        for n in itertools.count():
            if done.is_set():
                return
            text = f"rolling {n}"
            started = time.time()
            try:
                sent[text], body = topology.fetch("/api/robot/speech/", method="POST", body={"text": text},
                                                  user="otto", timeout=10)
            except OSError as exc:
                sent[text], body = 0, {"detail": str(exc)}
            if sent[text] != 200:
                why[text] = f"at +{started - began:.2f} s for {time.time() - started:.2f} s: {body}"
            time.sleep(0.1)

    def watcher() -> None:  # how old the newest robot state in the store gets
        while not done.wait(0.05):
            t = topology.store_entry("odom").get("t")
            if t is not None:
                stalest[0] = max(stalest[0], time.time() - float(t))

    threads = [threading.Thread(target=operator, daemon=True), threading.Thread(target=watcher, daemon=True)]
    for thread in threads:
        thread.start()
    try:
        for _ in range(2):
            active = topology.active_link()
            other = {"link-a": "link-b", "link-b": "link-a"}[active]
            before, stopped = topology.started(active), topology.log(active).count("Robot link stopped.")
            said = topology.script(f"restart {active}")  # SIGTERM: zero, flush, hand over, exit; start again
            # It stopped by itself (released the lease), not killed by stack.sh after ignoring SIGTERM, nor
            # by its own stop deadline (which writes every thread's stack to its log).
            log = topology.log(active)
            assert "ignored SIGTERM" not in said and "(most recent call first)" not in log, f"{said}\n{log[-6000:]}"
            assert log.count("Robot link stopped.") > stopped, f"{said}\n{log[-6000:]}"
            topology.wait(lambda o=other: topology.active_link() == o, timeout=15, what=f"{other} taking over")
            topology.wait(lambda a=active, b=before: topology.started(a) > b, timeout=60,
                          what=f"{active} back as the standby")
        for web in ("web-a", "web-b"):
            topology.script(f"restart {web}")
            assert "no longer listening" in topology.log(web), "the web process stopped without draining"
            time.sleep(1)
    finally:
        done.set()
        for thread in threads:
            thread.join(15)

    received = [m["data"] for m in topology.received(SPEECH) if m["data"].startswith("rolling ")]
    assert len(received) == len(set(received)), "a command reached the robot twice"
    answered = {text for text, status in sent.items() if status == 200}
    assert answered <= set(received), f"answered ok but never reached the robot: {answered - set(received)}"
    # A stopping web process finishes what it serves and nginx sends new requests to the other one; a stopping
    # link answers what it took and the one taking over serves what was queued meanwhile. Seen on a loaded
    # machine: now and then one command sent as the active link gets SIGTERM times out (504, never executed).
    failed = {text: (status, why.get(text), text in received) for text, status in sent.items() if status != 200}
    assert len(failed) <= 1, f"{failed}\n{topology.log('link-a')[-4000:]}\n{topology.log('link-b')[-4000:]}"
    assert stalest[0] < UNWATCHED_S, f"the robot went unwatched for {stalest[0]:.1f} s"
    # The page kept up by itself; recording lost at most a moment per handover, all of it counted.
    expect(dashboard.locator('[data-field="tts.last"]')).to_have_text(received[-1], timeout=5000)
    seqs = [seq for seq in _recorded(topology) if seq >= recorded_before]
    assert max(b - a - 1 for a, b in itertools.pairwise(seqs)) <= UNWATCHED_S * RATE_HZ, "a handover left a long gap"
    topology.wait(lambda: _history_lost(topology) == _missing(_recorded(topology)), timeout=10,
                  what="/healthz counting every message lost")


def test_a_redis_restart_is_survived_without_restarting_any_process(topology, dashboard):
    before = _pids(topology)
    dashboard.evaluate("window.sameDocument = true")
    topology.redis.stop()
    time.sleep(1)
    topology.redis.start()
    topology.wait(lambda: topology.health().get("connected") is True, timeout=15, what="the robot online again")
    topology.wait(lambda: topology.active_link() is not None, timeout=5, what="a link holding the lease")
    # The open page, never reloaded: its web process subscribed to live updates again by itself.
    _say_and_see(topology, dashboard, web=None, within_s=3, retry_s=10)
    expect(dashboard.locator("#link-pill")).to_have_text("robot online")
    assert dashboard.evaluate("window.sameDocument") is True
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


def test_a_forged_forwarded_address_neither_escapes_a_lockout_nor_lands_in_it(topology):
    """Through the shipped nginx, a client's own X-Forwarded-For is replaced by its real address:
    rotating forged addresses still counts every failure against the one that sent them."""

    def login(forged: str, password: str) -> int:
        request = urllib.request.Request(
            f"{topology.url}/api/auth/token/", method="POST",
            data=json.dumps({"username": "otto", "password": password}).encode(),
            headers={"Content-Type": "application/json", "Host": "localhost", "X-Forwarded-For": forged})
        try:
            with urllib.request.urlopen(request, timeout=5, context=_TLS) as res:
                return res.status
        except urllib.error.HTTPError as err:
            return err.code

    try:
        failures = [login(f"10.9.0.{n}", "wrong") for n in range(5)]  # LOGIN_FAILURE_LIMIT
        assert failures[:4] == [400] * 4 and failures[4] == 429, failures
        assert login("10.9.1.1", PASSWORD) == 429  # a fresh forged address does not get in
        rows = topology.manage("shell", "-c", "from axes.models import AccessAttempt\n"
                               "print(sorted({a.ip_address for a in AccessAttempt.objects.all()}))")
        assert rows.strip().splitlines()[-1] == "['127.0.0.1']", rows  # the real address, never a forged one
    finally:
        topology.manage("axes_reset")


def test_with_no_link_running_the_worker_alerts_once_and_a_link_running_again_ends_it(topology, http_server):
    topology.manage("shell", "-c", "from robot.alerts.models import Webhook\n"
                    f"Webhook.objects.create(name='chat', url='http://127.0.0.1:{http_server.server_address[1]}/',"
                    " kinds=['link_down'])")

    def link_down_on() -> list[dict]:
        return [a for a in topology.fetch("/api/alerts/", user="vera")[1]["on"] if a["kind"] == "link_down"]

    try:
        for link in ("link-a", "link-b"):
            topology.kill(link)
        topology.wait(lambda: http_server.received, timeout=30, what="the link_down alert at the webhook")
        alert = json.loads(http_server.received[0][2])["alert"]
        assert (alert["kind"], alert["severity"]) == ("link_down", "critical")
        assert [a["id"] for a in link_down_on()] == [alert["id"]]
        time.sleep(4 * LINK_WATCH_EVERY_S)  # more checks of the same outage send nothing more
        assert len(http_server.received) == 1
    finally:
        topology.script("restart link-a link-b")
    topology.wait(lambda: topology.health().get("connected") is True, timeout=60, what="the robot online again")
    topology.wait(lambda: not link_down_on(), timeout=15, what="link_down ended")
    history = topology.fetch("/api/alerts/?kind=link_down", user="vera")[1]["history"]
    assert next(a for a in history if a["id"] == alert["id"])["ended_at"] is not None
    assert len(http_server.received) == 1


def test_a_process_that_dies_is_started_again_like_the_units_do(topology):
    crashed = topology.crash("worker")
    topology.wait(lambda: topology.child("worker") != crashed and os.path.exists(f"/proc/{topology.child('worker')}"),
                  timeout=10, what="the worker started again")
    assert topology.alive("worker")
    assert "exited; starting it again" in topology.log("worker")


def test_taking_an_operators_role_closes_their_sockets_in_both_web_processes_within_a_second(topology):
    """Drive socket on one web process, audio socket on the other, a token trusted by both: the
    role is taken away by another process (manage.py), and each hears it through the channel layer."""
    import asyncio

    from websockets.asyncio.client import connect
    from websockets.exceptions import ConnectionClosed

    cookie = topology.login_cookie("otto")
    token = topology.token("otto")
    for web in (0, 1):  # each web process now trusts the token from its cache
        assert topology.fetch("/api/robot/state/", web=web, user="otto")[0] == 200
    cmd_vel = ri.topic("cmd_vel").name

    async def scenario() -> tuple[list[int | None], float]:
        headers = {"Cookie": cookie, "X-Forwarded-Proto": "https"}
        origin = f"https://localhost:{topology.https_port}"
        drive = await connect(f"ws://127.0.0.1:{topology.web_ports[0]}/ws/teleop/", origin=origin,
                              additional_headers=headers)
        audio = await connect(f"ws://127.0.0.1:{topology.web_ports[1]}/ws/audio/", origin=origin,
                              additional_headers=headers)
        await drive.recv()  # the lock frame
        before = len(await asyncio.to_thread(topology.received, cmd_vel))
        await drive.send(json.dumps({"type": "input", "linear": 0.3, "angular": 0.0}))
        while not any(m["linear"]["x"] > 0 for m in (await asyncio.to_thread(topology.received, cmd_vel))[before:]):
            await asyncio.sleep(0.05)
        await asyncio.to_thread(topology.manage, "shell", "-c",
                                "from django.contrib.auth.models import Group, User\n"
                                "User.objects.get(username='otto').groups.set([Group.objects.get(name='viewer')])")
        demoted = time.monotonic()
        codes = []
        for socket in (drive, audio):
            try:
                async with asyncio.timeout(1.0):
                    async for _ in socket:
                        pass
            except (TimeoutError, ConnectionClosed):
                pass
            codes.append(socket.close_code)
        return codes, demoted

    try:
        # A thread of its own: the module's browser (Playwright) keeps an event loop on this one.
        with concurrent.futures.ThreadPoolExecutor(1) as thread:
            codes, demoted = thread.submit(asyncio.run, scenario()).result()
        assert codes == [4403, 4403], codes
        stopped = topology.received(cmd_vel)[-1]
        assert stopped["linear"]["x"] == 0 and stopped["angular"]["z"] == 0
        # The token: refused by both processes within a second of the change (it is a viewer's now).
        while time.monotonic() - demoted < 1.0:
            time.sleep(0.05)
        for web in (0, 1):
            status, _ = topology.fetch("/api/robot/speech/", web=web, method="POST", body={"text": "hi"}, user="otto")
            assert status == 403, (web, status)
        topology.manage("shell", "-c", f"from rest_framework.authtoken.models import Token\n"
                        f"Token.objects.filter(key={token!r}).delete()")
        time.sleep(0.6)
        for web in (0, 1):
            assert topology.fetch("/api/robot/state/", web=web, user="otto")[0] == 401
    finally:
        topology.tokens.pop("otto", None)
        topology.manage("shell", "-c", "from django.contrib.auth.models import Group, User\n"
                        "User.objects.get(username='otto').groups.set([Group.objects.get(name='operator')])")


def test_rosbridge_tools_work_through_either_web_process(topology):
    """The front door on each Daphne, neither holding the link: an unmodified roslibpy viewer watches
    odometry and an operator drives under the drive lock until the deadman's zero."""
    import roslibpy

    from tests.sim.support import Inbox

    cmd_vel, odom_topic = ri.topic("cmd_vel").name, ri.topic("odom").name
    forward = {"linear": {"x": 0.3, "y": 0, "z": 0}, "angular": {"x": 0, "y": 0, "z": 0}}

    def tool(web: int, user: str) -> roslibpy.Ros:
        status, body = topology.fetch("/api/frontdoor/ticket/", web=web, method="POST", user=user)
        assert status == 200, body
        ros = roslibpy.Ros(f"ws://127.0.0.1:{topology.web_ports[web]}/rosbridge/?ticket={body['ticket']}")
        ros.run(timeout=30)
        return ros

    for web in (0, 1):
        viewer, operator = tool(web, "vera"), tool(web, "olga")
        try:
            odom = Inbox()
            roslibpy.Topic(viewer, odom_topic, "nav_msgs/Odometry").subscribe(odom)
            odom.wait(lambda items: len(items) >= 3, timeout=30, what=f"odometry on web {'ab'[web]}")
            before = len(topology.received(cmd_vel))
            cmd = roslibpy.Topic(operator, cmd_vel, "geometry_msgs/Twist")
            cmd.advertise()
            for _ in range(10):
                cmd.publish(roslibpy.Message(forward))
                time.sleep(0.1)
            deadline = time.monotonic() + 20
            while not any(m["linear"]["x"] > 0.2 for m in topology.received(cmd_vel)[before:]):
                assert time.monotonic() < deadline, f"no forward command through web {'ab'[web]}"
                time.sleep(0.1)
            while topology.received(cmd_vel)[-1]["linear"]["x"] != 0.0:  # the tool stopped: the deadman
                assert time.monotonic() < deadline + 10, "no deadman's zero"
                time.sleep(0.1)
        finally:
            viewer.close()
            operator.close()
