"""Fixtures shared by the whole suite: users by role, the simulator, the robot link."""

from __future__ import annotations

import asyncio
import io
import sys
import threading
import traceback
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest
from channels.layers import channel_layers
from django.conf import settings as django_settings
from pytest_django.plugin import pytest_collection_modifyitems as django_order

from cyborg_site.roles import Role
from tests.browser.support import browser, page, sized_page, stack  # noqa: F401  (shared session fixtures)
from tests.helpers import async_wait_until, wait_until

PASSWORD = "correct-horse-battery"

pytest_plugins = ["tests.wiring"]


TASK_STOP_S = 15.0


def _cancel_all_tasks_naming_stragglers(loop: asyncio.AbstractEventLoop) -> None:
    """``asyncio.Runner``'s clean-up at the end of each async test, bounded: a task that ignores its
    cancellation would otherwise hang the run until the test's timeout without naming itself."""
    tasks = [task for task in asyncio.all_tasks(loop) if not task.done()]
    if not tasks:
        return
    for task in tasks:
        task.cancel()
    done, pending = loop.run_until_complete(asyncio.wait(tasks, timeout=TASK_STOP_S))
    for task in done:
        if not task.cancelled() and task.exception() is not None:
            loop.call_exception_handler({"message": "unhandled exception during asyncio.run() shutdown",
                                         "exception": task.exception(), "task": task})
    if pending:
        stacks = []
        for task in pending:
            out = io.StringIO()
            task.print_stack(file=out)
            stacks.append(out.getvalue() + _awaiting(task))
        raise RuntimeError(f"{len(pending)} task(s) still running {TASK_STOP_S:g} s after being cancelled:\n"
                           + "\n".join(stacks))


def _awaiting(task: asyncio.Task) -> str:
    """Where the task waits, through every coroutine it awaits (``print_stack`` shows its first frame only)."""
    lines = []
    awaited = getattr(task.get_coro(), "cr_await", None)
    while awaited is not None:
        frame = getattr(awaited, "cr_frame", None) or getattr(awaited, "gi_frame", None)
        if frame is None:
            lines.append(f"  awaiting {awaited!r}")
            break
        lines.append(f"  awaiting {frame.f_code.co_qualname} at {frame.f_code.co_filename}:{frame.f_lineno}")
        awaited = getattr(awaited, "cr_await", None) or getattr(awaited, "gi_yieldfrom", None)
    return "\n".join(lines)


asyncio.runners._cancel_all_tasks = _cancel_all_tasks_naming_stragglers  # type: ignore[attr-defined]

_shutdown_default_executor = asyncio.BaseEventLoop.shutdown_default_executor


async def _shutdown_default_executor_naming_stragglers(
    self: asyncio.BaseEventLoop, timeout: float | None = None
) -> None:
    """The same clean-up's wait for the loop's worker threads, bounded: a call still blocked (say, a
    database write waiting on a lock the test's own transaction holds until after this) is named
    with its stack instead of hanging the run; it ends by itself once the transaction does."""
    try:
        await asyncio.wait_for(asyncio.shield(_shutdown_default_executor(self)), TASK_STOP_S)
    except TimeoutError:
        frames = sys._current_frames()
        stacks = ["".join(traceback.format_stack(frames[t.ident])) for t in threading.enumerate()
                  if t.name.startswith("asyncio_") and t.ident in frames]
        raise RuntimeError(f"the event loop's worker threads were still busy {TASK_STOP_S:g} s after the test:\n"
                           + "\n".join(stacks)) from None


asyncio.BaseEventLoop.shutdown_default_executor = _shutdown_default_executor_naming_stragglers  # type: ignore[method-assign]


BROWSER_GROUPS = 2


@pytest.hookimpl(hookwrapper=True)
def pytest_collection_modifyitems(config, items):
    """After every plugin's ordering (testmon's by duration comes last): pytest-django's order again,
    plain database tests before transactional ones, whose flush empties the tables migrations seed.
    Browser tests last: Playwright's sync API leaves an event loop running in the main
    thread, which async tests after it cannot share. Under xdist they run in two groups by file,
    each on one worker: a worker's first browser test starts a stack and a Chromium that run (and
    cost CPU) until the session ends, so spreading them over every worker costs more than it saves."""
    yield
    django_order(items)
    items.sort(key=lambda item: any(item.get_closest_marker(m) is not None for m in ("browser", "stack")))
    files = sorted({item.path for item in items if item.get_closest_marker("browser")})
    for item in items:
        if item.get_closest_marker("browser"):
            item.add_marker(pytest.mark.xdist_group(f"browser-{files.index(item.path) % BROWSER_GROUPS}"))


# --- users by role -----------------------------------------------------------------------


@pytest.fixture(autouse=True, scope="session")
def _few_rounds_password_hashing():
    from django.test import override_settings

    with override_settings(PASSWORD_HASHERS=["tests.hashing.FewRoundsPBKDF2PasswordHasher"]):
        yield


def _user(username: str, role: Role):
    from cyborg_site.roles import role_of
    from dashboard.accounts import create_user
    from robot.models import AuditEntry

    user = create_user(username, role, password=PASSWORD)[0]
    # A test's accounts were there before it: its audit holds only what the test itself did.
    AuditEntry.objects.filter(action__startswith="account.").delete()
    # Prime the role cache so async consumers in tests need no query from another thread
    # (the test's transaction holds SQLite's in-memory tables).
    role_of(user)
    return user


@pytest.fixture
def viewer(db):
    return _user("vera", Role.VIEWER)


@pytest.fixture
def operator(db):
    return _user("otto", Role.OPERATOR)


@pytest.fixture
def admin_user(db):
    return _user("ada", Role.ADMIN)


@pytest.fixture
def admin_logged_in(admin_user):
    """Django's test client, logged in as the admin (for the admin site's pages)."""
    from django.test import Client

    client = Client()
    client.force_login(admin_user)
    return client


def _api_client(user=None):
    from rest_framework.test import APIClient

    client = APIClient()
    if user is not None:
        client.force_authenticate(user)
    return client


@pytest.fixture
def anon_api():
    return _api_client()


@pytest.fixture
def viewer_api(viewer):
    return _api_client(viewer)


@pytest.fixture
def operator_api(operator):
    return _api_client(operator)


@pytest.fixture
def admin_api(admin_user):
    return _api_client(admin_user)


# --- backing services ----------------------------------------------------------------------


@pytest.fixture(autouse=True, scope="session")
def _private_redis_prefix():
    """Concurrent test runs on one Redis must not see each other's channels and state."""
    import os

    if not django_settings.EMBEDDED:
        django_settings.CHANNEL_LAYERS["default"]["CONFIG"]["prefix"] = f"cyborg-test-{os.getpid()}"


@pytest.fixture(scope="session")
def django_db_setup(django_db_setup):
    """pytest-django's, with the audit writer's connection closed before the test database is
    dropped (a refusal audited after its test ended may have opened it again)."""
    yield
    from robot.commands.audit_writer import writer

    writer.close_connection()


@pytest.fixture(autouse=True)
def _audit_writer_connection_closed(tmp_path):
    """The audit writer keeps its connection between writes; a test ends with it closed, so the
    next test's flush and the test database's drop meet no other session. Each test has an audit
    journal of its own, and starts with the writer up. (override_settings, not the settings
    fixture: that one, set up this early, would be undone after the other fixtures' teardown.)"""
    from django.test import override_settings

    from robot.commands.audit_writer import writer

    writer.down = False
    with override_settings(AUDIT_JOURNAL_DIR=tmp_path / "audit-journal"):
        yield
        writer.down = False  # no probe after the test
        writer.close_connection()


@pytest.fixture(autouse=True)
def _sync_to_async_connection_closed():
    """Async tests' ORM calls run on asgiref's one shared thread, whose connection outlives them:
    closed after each test, or PostgreSQL waits 5 s for it before refusing to drop the test database."""
    yield
    from asgiref.sync import SyncToAsync
    from django.db import connections

    SyncToAsync.single_thread_executor.submit(connections.close_all).result(10)


@pytest.fixture(autouse=True)
def _fresh_layer_and_store(_private_redis_prefix):
    """Each test gets an empty Redis (channel layer, latest-state store, queues, locks): the embedded
    pass empties its worker's private server, once a test started it; the services pass deletes its prefix's keys."""
    from robot import interface

    channel_layers.backends = {}
    _empty_redis()
    interface.reload()
    yield
    _empty_redis()
    channel_layers.backends = {}


def _empty_redis() -> None:
    from robot.live import private_server, redis_clients
    from robot.live.state import get_store, reset_store

    reset_store()
    if not django_settings.EMBEDDED:
        get_store().clear()
    elif private_server.running() and private_server.is_private(django_settings.REDIS_URL):
        redis_clients.client().flushall()


@pytest.fixture
def sim(request):
    """A simulated Cyborg on a free port, in a thread of its own; parametrize it (indirect) with 2 for
    a ROS 2 robot (``EITHER_ROS``)."""
    from simulator.harness import SimThread

    with SimThread(port=0, video_port=0, startup_s=0.5, ros=getattr(request, "param", 1)) as running:
        yield running


# Robot-facing tests whose behaviour depends on the robot's ROS run against both.
EITHER_ROS = pytest.mark.parametrize("sim", [1, 2], indirect=True, ids=["ros1", "ros2"])


async def hosted_link(url: str, settings, *, timeout: float = 10):
    """The robot link hosted on the test's event loop, connected to ``url`` (no background services)."""
    from robot import supervisor
    from robot.link.hosting import start_link

    settings.ROSBRIDGE_URL = url
    hosted, tasks = await start_link(embedded=True, background=False)
    await async_wait_until(lambda: hosted.connected, timeout=timeout, what="link connected")
    yield hosted
    for task in tasks:
        task.cancel()
    await hosted.stop()
    supervisor.release(hosted)


@pytest.fixture
async def link(sim, settings):
    async for hosted in hosted_link(sim.url, settings):
        yield hosted


class LinkThread:
    """The robot link on an event loop in a thread, for synchronous tests (API views)."""

    def __init__(self, *, background: bool = False) -> None:
        self.background = background
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.link = None
        self.tasks: list = []

    def start(self):
        from robot.link.hosting import start_link

        self.thread.start()
        self.link, self.tasks = asyncio.run_coroutine_threadsafe(
            start_link(embedded=True, background=self.background), self.loop
        ).result(10)
        wait_until(lambda: self.link.connected, timeout=10, what="link connected")
        return self.link

    def stop(self) -> None:
        from robot import supervisor

        async def _stop():
            for task in self.tasks:
                task.cancel()
            await self.link.stop()

        asyncio.run_coroutine_threadsafe(_stop(), self.loop).result(20)
        supervisor.release(self.link)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5)


@pytest.fixture
def link_thread(sim, settings):
    settings.ROSBRIDGE_URL = sim.url
    runner = LinkThread()
    runner.start()
    wait_until(lambda: runner.link.dial.ros_version == sim.robot.ros, timeout=10, what="the link to find the ROS")
    yield runner.link
    runner.stop()


class Recorder(BaseHTTPRequestHandler):
    """A local HTTP server that keeps what it is sent and answers with the next queued status."""

    def do_POST(self):
        body = self.rfile.read(int(self.headers.get("Content-Length", 0)))
        self.server.received.append((self.path, {k.lower(): v for k, v in self.headers.items()}, body))
        status = self.server.statuses.pop(0) if self.server.statuses else 201
        self.send_response(status)
        self.send_header("Content-Length", "0")
        self.end_headers()

    def log_message(self, *args):
        pass


@pytest.fixture
def http_server():
    """A local HTTP server: a chat tool's webhook or a push service stand-in (alerts)."""
    server = ThreadingHTTPServer(("127.0.0.1", 0), Recorder)
    server.received, server.statuses = [], []
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield server
    server.shutdown()
    server.server_close()
