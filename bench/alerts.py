"""Alerts through the real product: an embedded stack (simulator process + Daphne) and headless Chromium.

- ``alert_to_every_page_p99_ms``: a ROS node's FATAL line on /rosout (published over rosbridge with
  unmodified roslibpy) until the alert is shown on every one of 5 open pages (Dashboard, Drive, Map,
  History, Alerts), each page stamping the moment with a MutationObserver; p99 over every page.
- ``robot_hang_to_not_responding_ms``: the simulator frozen with SIGSTOP until a page's pill says
  "not responding" (worst of several freezes).
- ``alert_to_email_ms``: the same kind of line until the mail is in a real SMTP server's maildir (aiosmtpd).
- ``alert_to_push_ms``: until a local push service stand-in receives the encrypted Web Push message.
- ``link_down_to_webhook_s``: scaled (private Redis, one robot link, a Celery worker with its beat, the
  default LINK_DOWN_ALERT_S and LINK_WATCH_EVERY_S), the link killed until its link_down alert reaches a
  webhook: how long a robot nobody watches goes unsaid.

Prints ``name: value`` lines; the machine may be shared.
"""

from __future__ import annotations

import base64
import mailbox
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import roslibpy  # noqa: E402
from cryptography.hazmat.primitives import serialization  # noqa: E402
from cryptography.hazmat.primitives.asymmetric import ec  # noqa: E402

from bench._stats import quantile  # noqa: E402
from robot import interface as ri  # noqa: E402
from tests.browser.support import CHROMIUM, CHROMIUM_ARGS  # noqa: E402
from tests.browser.support import login as page_login  # noqa: E402
from tests.stack import PYTHON, Stack, free_port, wait_for_port  # noqa: E402
from tests.support_processes import PrivateRedis  # noqa: E402

EVENTS = 30
HANGS = 3
DELIVERIES = 10
PAGE_PATHS = ["/", "/drive/", "/map/", "/history/", "/alerts/"]

# Each page records when an alert with a given key first shows in its header strip, and when the pill changes.
OBSERVE = """() => {
  window.seen = {}; window.pillAt = {};
  const strip = document.getElementById('alert-strip'), pill = document.getElementById('link-pill');
  const look = () => strip.querySelectorAll('[data-alert-key]').forEach((el) => {
    window.seen[el.dataset.alertKey] ??= Date.now();
  });
  new MutationObserver(look).observe(strip, {childList: true, subtree: true});
  new MutationObserver(() => { window.pillAt[pill.textContent] ??= Date.now(); })
    .observe(pill, {childList: true, characterData: true, subtree: true});
}"""


class PushService(BaseHTTPRequestHandler):
    def do_POST(self):
        self.rfile.read(int(self.headers.get("Content-Length", 0)))
        self.server.received.append(time.time())
        self.send_response(201)
        self.send_header("Content-Length", "0")
        self.end_headers()

    def log_message(self, *args):
        pass


def b64(raw: bytes) -> str:
    return base64.urlsafe_b64encode(raw).rstrip(b"=").decode()


def choose_delivery(stack: Stack, push_url: str) -> None:
    """Otto wants FATAL/ERROR lines by e-mail and Web Push (one subscription, at the stand-in)."""
    key = ec.generate_private_key(ec.SECP256R1()).public_key().public_bytes(
        serialization.Encoding.X962, serialization.PublicFormat.UncompressedPoint)
    stack.manage("shell", "-c", f"""
from django.contrib.auth.models import User
from robot.alerts.models import AlertChoice, PushSubscription
otto = User.objects.get(username="otto"); otto.email = "otto@example.org"; otto.save()
AlertChoice.objects.create(user=otto, by_email=True, by_push=True, kinds=["log"])
PushSubscription.objects.create(user=otto, endpoint={push_url!r}, p256dh={b64(key)!r}, auth={b64(os.urandom(16))!r})
""")


def main() -> None:
    from playwright.sync_api import sync_playwright

    tmp = Path(tempfile.mkdtemp(prefix="bench-alerts-"))
    smtp_port, maildir = free_port(), tmp / "maildir"
    smtp = subprocess.Popen([sys.executable, "-m", "aiosmtpd", "-n", "-l", f"127.0.0.1:{smtp_port}",
                             "-c", "aiosmtpd.handlers.Mailbox", str(maildir)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    push = ThreadingHTTPServer(("127.0.0.1", 0), PushService)
    push.received = []
    threading.Thread(target=push.serve_forever, daemon=True).start()
    env = {"EMAIL_HOST": "127.0.0.1", "EMAIL_PORT": str(smtp_port), "READ_THROTTLE_PER_S": "0"}
    try:
        wait_for_port(smtp_port, proc=smtp)
        with Stack(env=env) as stack, sync_playwright() as p:
            stack.wait_robot_online()
            choose_delivery(stack, f"http://127.0.0.1:{push.server_address[1]}/push/bench")
            browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            context = browser.new_context(viewport={"width": 1366, "height": 800})
            pages = []
            for path in PAGE_PATHS:
                page = context.new_page()
                if pages:
                    page.goto(f"{stack.url}{path}")
                else:
                    page_login(page, stack, "vera", next_path=path)
                page.locator("#link-pill").filter(has_text="robot online").wait_for(timeout=20_000)
                page.evaluate(OBSERVE)
                pages.append(page)
            ros = roslibpy.Ros("127.0.0.1", stack.sim_port)
            ros.run(timeout=10)
            rosout = roslibpy.Topic(ros, ri.topic("rosout").name, ri.topic("rosout").type)
            rosout.advertise()
            time.sleep(0.5)

            def inbox() -> int:
                return len(list(mailbox.Maildir(str(maildir), create=False))) if maildir.exists() else 0

            sent: dict[str, float] = {}
            to_mail: list[float] = []
            to_push: list[float] = []
            for i in range(EVENTS):
                node = f"/bench_{i}"
                mails, pushes = inbox(), len(push.received)
                sent[node] = time.time()
                rosout.publish(roslibpy.Message({"level": 16, "name": node, "msg": f"bench {i}"}))
                if i < DELIVERIES:
                    mail_at = push_at = None
                    deadline = time.monotonic() + 10
                    while time.monotonic() < deadline and (mail_at is None or push_at is None):
                        if mail_at is None and inbox() > mails:
                            mail_at = time.time()
                        if push_at is None and len(push.received) > pushes:
                            push_at = push.received[pushes]
                        time.sleep(0.005)
                    to_mail.append((mail_at - sent[node]) * 1000 if mail_at else float("nan"))
                    to_push.append((push_at - sent[node]) * 1000 if push_at else float("nan"))
                time.sleep(0.3)
            time.sleep(2)
            shown: list[float] = []
            missing = 0
            for page in pages:
                seen = page.evaluate("window.seen")
                for node, at in sent.items():
                    if f"log:{node}" in seen:
                        shown.append(seen[f"log:{node}"] - at * 1000)
                    else:
                        missing += 1

            hangs: list[float] = []
            for _ in range(HANGS):
                for page in pages[:1]:
                    page.evaluate("window.pillAt = {}")
                frozen = time.time()
                os.kill(stack.sim_proc.pid, signal.SIGSTOP)
                try:
                    pages[0].locator("#link-pill").filter(has_text="not responding").wait_for(timeout=10_000)
                    hangs.append(pages[0].evaluate("window.pillAt['not responding']") - frozen * 1000)
                finally:
                    os.kill(stack.sim_proc.pid, signal.SIGCONT)
                pages[0].locator("#link-pill").filter(has_text="robot online").wait_for(timeout=15_000)
                time.sleep(1)
            ros.close()
            browser.close()
    finally:
        push.shutdown()
        smtp.terminate()
        smtp.wait(10)

    shown.sort()
    print(f"alert_to_every_page_p50_ms: {quantile(shown, 0.5):.0f}")
    print(f"alert_to_every_page_p99_ms: {quantile(shown, 0.99):.0f}")
    print(f"alert_pages_missed: {missing}")
    print(f"robot_hang_to_not_responding_ms: {max(hangs):.0f}")
    print(f"alert_to_email_ms: {quantile(sorted(to_mail), 0.5):.0f}")
    print(f"alert_to_email_max_ms: {max(to_mail):.0f}")
    print(f"alert_to_push_ms: {quantile(sorted(to_push), 0.5):.0f}")
    print(f"alert_to_push_max_ms: {max(to_push):.0f}")

    print(f"link_down_to_webhook_s: {link_down_to_webhook_s():.1f}")


def link_down_to_webhook_s() -> float:
    hook = ThreadingHTTPServer(("127.0.0.1", 0), PushService)
    hook.received = []
    threading.Thread(target=hook.serve_forever, daemon=True).start()
    redis = PrivateRedis().start()
    try:
        with Stack(redis_url=redis.url) as stack:
            stack.manage("shell", "-c", "from robot.alerts.models import Webhook\nWebhook.objects.create("
                         f"name='chat', url='http://127.0.0.1:{hook.server_address[1]}/', kinds=['link_down'])")
            worker = stack._spawn([PYTHON, "-m", "celery", "-A", "cyborg_site", "worker", "--beat", "--pool=solo",
                                   "--loglevel=INFO", "--without-gossip", "--without-mingle",
                                   f"--schedule={stack.tmp / 'beat'}"],
                                  "worker")
            stack.wait_robot_online()
            deadline = time.monotonic() + 60
            while "ready" not in stack.log("worker"):
                assert worker.poll() is None and time.monotonic() < deadline, stack.log("worker")[-3000:]
                time.sleep(0.2)
            time.sleep(2)  # a few checks with the link up
            killed = time.time()
            os.killpg(stack.link_proc.pid, signal.SIGKILL)
            while not hook.received:
                assert time.time() - killed < 120, stack.log("worker")[-3000:]
                time.sleep(0.05)
            return hook.received[0] - killed
    finally:
        hook.shutdown()
        redis.stop()


if __name__ == "__main__":
    main()
