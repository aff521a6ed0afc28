"""Failover of the production topology: processes and services killed for real, recovery timed.

scripts/stack.sh runs nginx, two Daphne, two robot links, Celery worker + beat and the simulator
(/odom and /robot_pose at 20 Hz) on a private redis-server and a private PostgreSQL. Figures:

  link_failover_s            SIGKILL of the link holding the lease -> the standby holds it and a
                             fresh /odom message is in the latest-state store
  link_failover_lost_msgs    /odom recorded every message: messages missing around that failover
                             (the simulator numbers each /odom in header.seq, 20 Hz)
  link_failover_counted_msgs the same loss as the product counts it (/healthz history_lost_in_handovers)
  web_failover_s             SIGKILL of the Daphne serving a browser's live socket -> that page
                             gets a live frame again (through the other Daphne)
  redis_restart_recovery_s   redis-server killed and started again -> a command through nginx is
                             answered and the open page shows its effect
  robot_return_reconnect_s   simulator killed for 3 s; its port listening again -> link connected
  worker_outage_lost_samples Celery worker SIGKILLed for 10 s, /robot_pose sampled every 1 s:
                             samples missing in that stretch once the worker is back
"""

from __future__ import annotations

import itertools
import os
import socket
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tests.deploy.topology import PrivatePostgres, Topology  # noqa: E402
from tests.support_processes import PrivateRedis  # noqa: E402

RATE_HZ = 20.0
INTERVAL_S = 1.0
OUTAGE_S = 10.0


def rows(topic: str, start: float, end: float) -> list[tuple[float, dict]]:
    """(receive time, message) of the recorded samples of ``topic`` in [start, end]."""
    from history.models import Sample
    from history.storage import utc

    qs = Sample.objects.filter(topic=topic, received_at__gte=utc(start), received_at__lte=utc(end))
    return [(at.timestamp(), data) for at, data in qs.order_by("received_at").values_list("received_at", "data")]


def set_policies(topo: Topology) -> None:
    topo.manage("shell", "-c", (
        "from history.policies import policy_upsert\n"
        f"policy_upsert(topic='/robot_pose', msg_type='geometry_msgs/Pose', mode='periodic', interval_s={INTERVAL_S})\n"
    ))
    topo.record_every("/odom", "nav_msgs/Odometry")


def link_failover(topo: Topology, database_url: str) -> tuple[float, int, int]:
    active = topo.active_link()
    standby = {"link-a": "link-b", "link-b": "link-a"}[active]
    time.sleep(3)  # recording under way on both sides of the kill
    killed = time.time()
    topo.kill(active)
    topo.wait(lambda: topo.active_link() == standby and topo.store_entry("odom").get("t", 0) > killed,
              timeout=30, what="the standby holding the lease with /odom flowing", every=0.01)
    took = time.time() - killed
    time.sleep(4)  # the new holder's recorder flushes
    seqs = topo.recorded_seqs(database_url, "/odom")
    lost = sum(b - a - 1 for a, b in itertools.pairwise(seqs) if b > a)
    counted = topo.health(details=True).get("history_lost_in_handovers", {}).get("/odom", -1)
    topo.script(f"restart {active}")
    return took, lost, counted


def web_failover(topo: Topology, browser) -> float:
    from tests.browser.support import login

    context = browser.new_context(ignore_https_errors=True)
    page = context.new_page()
    sockets: list = []
    frames: dict[int, float] = {}

    def opened(ws) -> None:
        sockets.append(ws)
        ws.on("framereceived", lambda _: frames.setdefault(id(ws), time.time()))

    page.on("websocket", opened)
    login(page, topo, "vera")
    page.wait_for_function("() => document.querySelector('#link-pill').textContent === 'robot online'")
    try:
        for victim in ("web-a", "web-b"):
            live = sockets[-1]
            killed = time.time()
            topo.kill(victim)
            deadline = time.time() + 1.5
            while time.time() < deadline and not live.is_closed():
                page.wait_for_timeout(20)
            if not live.is_closed():
                topo.script(f"restart {victim}")  # the page was on the other one
                time.sleep(2)
                continue
            while not (sockets[-1] is not live and id(sockets[-1]) in frames):
                if time.time() - killed > 30:
                    raise RuntimeError("the page never came back")
                page.wait_for_timeout(10)
            took = frames[id(sockets[-1])] - killed
            topo.script(f"restart {victim}")
            return took
        raise RuntimeError("killing either web process left the page's socket open")
    finally:
        context.close()


def redis_restart(topo: Topology, redis_server: PrivateRedis, browser) -> float:
    from tests.browser.support import login

    context = browser.new_context(ignore_https_errors=True)
    page = context.new_page()
    login(page, topo, "vera")
    topo.token("otto")
    redis_server.stop()
    redis_server.start()
    back = time.time()
    n = 0
    while True:
        n += 1
        text = f"back {n}"
        try:
            status, _ = topo.fetch("/api/robot/speech/", method="POST", body={"text": text}, user="otto", timeout=2)
        except OSError:
            status = 0
        if status == 200:
            try:
                page.wait_for_function(
                    f"() => document.querySelector('[data-field=\"tts.last\"]').textContent === {text!r}",
                    timeout=1000)
                break
            except Exception:
                pass
        if time.time() - back > 60:
            raise RuntimeError("no recovery within 60 s")
        time.sleep(0.05)
    took = time.time() - back
    context.close()
    return took


def robot_return(topo: Topology) -> float:
    port = int(topo.env["STACK_SIM_PORT"])
    topo.kill("sim")
    topo.wait(lambda: not topo.store_entry("_link").get("connected"), timeout=10, what="the link noticing")
    time.sleep(3)
    topo.script("restart sim")
    while True:
        try:
            socket.create_connection(("127.0.0.1", port), 0.2).close()
            break
        except OSError:
            time.sleep(0.01)
    listening = time.time()
    topo.wait(lambda: topo.store_entry("_link").get("connected") is True, timeout=30, what="the link reconnected",
              every=0.01)
    return time.time() - listening


def worker_outage(topo: Topology) -> int:
    time.sleep(3)
    killed = time.time()
    topo.kill("worker")
    time.sleep(OUTAGE_S)
    topo.script("restart worker")
    time.sleep(8)  # the worker starts and the next beat tick catches up
    times = [t for t, _ in rows("/robot_pose", killed - 2, killed + OUTAGE_S + 2)]
    # One sample per interval: every gap of n intervals means n - 1 samples lost.
    return sum(max(0, round((b - a) / INTERVAL_S) - 1) for a, b in itertools.pairwise(times))


def main() -> None:
    redis_server = PrivateRedis().start()
    postgres = PrivatePostgres().start()
    topo = Topology(redis_url=redis_server.url, database_url=postgres.url)
    topo.env["STACK_SIM_ARGS"] = f"--pose-rate {RATE_HZ:g}"
    os.environ.update({"DATABASE_URL": postgres.url, "REDIS_URL": redis_server.url,
                       "CHANNEL_LAYER_PREFIX": topo.prefix, "DJANGO_SETTINGS_MODULE": "cyborg_site.settings"})
    from playwright.sync_api import sync_playwright

    from tests.browser.support import CHROMIUM, CHROMIUM_ARGS

    try:
        topo.up()
        import django

        django.setup()
        set_policies(topo)
        figures: dict[str, float] = {}
        (figures["link_failover_s"], figures["link_failover_lost_msgs"],
         figures["link_failover_counted_msgs"]) = link_failover(topo, postgres.url)
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            figures["web_failover_s"] = web_failover(topo, browser)
            figures["redis_restart_recovery_s"] = redis_restart(topo, redis_server, browser)
            browser.close()
        figures["robot_return_reconnect_s"] = robot_return(topo)
        figures["worker_outage_lost_samples"] = worker_outage(topo)
        for name, value in figures.items():
            print(f"{name}: {value:.2f}" if name.endswith("_s") else f"{name}: {value:g}")
    finally:
        topo.down()
        redis_server.stop()
        postgres.remove()


if __name__ == "__main__":
    main()
