"""Which tests depend on the wiring, and so run in both passes (embedded, then PostgreSQL + Redis).

A test depends on the wiring when it uses the database (the ``db`` fixture, a ``django_db`` mark),
the robot link, a stack of processes, Redis or PostgreSQL, or the latest-state store or the
channel layer while it runs: those have an in-memory and a real implementation. Everything else
(pure functions, the simulator on its own, page scripts) is the same in both passes and runs in
the embedded pass only.

Fixtures and marks say most of it. For the rest the embedded pass watches the in-memory store and
channel layer during each test's call: a test that used either without the ``wiring`` mark fails
and says so, so a new test cannot quietly drop out of the services pass.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable, Iterator
from typing import Any

import pytest

WIRING = "wiring"
WIRING_MARKS = frozenset({WIRING, "django_db", "redis", "postgres", "stack"})
WIRING_FIXTURES = frozenset({"db", "transactional_db", "link", "link_thread", "live_server", "uses_redis"})

_touched: set[str] = set()


def depends_on_wiring(item: pytest.Item) -> bool:
    if any(item.get_closest_marker(name) is not None for name in WIRING_MARKS):
        return True
    return bool(WIRING_FIXTURES & set(getattr(item, "fixturenames", ())))


def _noting(what: str, method: Callable[..., Any], configured: Callable[[Any], bool]) -> Callable[..., Any]:
    @functools.wraps(method)
    def noted(self: Any, *args: Any, **kwargs: Any) -> Any:
        if configured(self):
            _touched.add(what)
        return method(self, *args, **kwargs)

    return noted


def _watch(cls: type, what: str, names: tuple[str, ...], configured: Callable[[Any], bool]) -> None:
    for name in names:
        setattr(cls, name, _noting(what, getattr(cls, name), configured))


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", f"{WIRING}: depends on the channel layer, database engine or Redis "
                                       "(runs in both passes; most tests get it from their fixtures)")
    if os.environ.get("REDIS_URL"):
        return
    from channels.layers import InMemoryChannelLayer, channel_layers

    from robot.live import state
    from robot.live.state import MemoryStore

    # Only the configured ones: a test may make an in-memory store or layer of its own on purpose.
    _watch(MemoryStore, "the latest-state store",
           ("aput", "put", "aget_many", "get_all", "aappend_recent", "aget_recent", "get_recent"),
           lambda store: store is state._store)
    _watch(InMemoryChannelLayer, "the channel layer", ("send", "receive", "new_channel", "group_add", "group_send"),
           lambda layer: layer in channel_layers.backends.values())


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if depends_on_wiring(item):
            item.add_marker(WIRING)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Iterator[pytest.TestReport]:
    """In the embedded pass, a test that skips itself and is not marked runs in no pass at all."""
    report: pytest.TestReport = yield
    if (report.when == "setup" and report.skipped and not os.environ.get("REDIS_URL")
            and not depends_on_wiring(item)):
        report.outcome = "failed"
        report.longrepr = (f"{item.nodeid} skips itself in the embedded pass ({report.longrepr!r}) but is not "
                           f"marked `{WIRING}` (or redis, postgres, stack): it would run in no pass")
    return report


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item: pytest.Item) -> Iterator[None]:
    _touched.clear()
    result = yield
    if _touched and not depends_on_wiring(item):
        pytest.fail(f"this test used {' and '.join(sorted(_touched))} but is not marked `{WIRING}`: "
                    "mark it (pytestmark = pytest.mark.wiring) so the services pass runs it too", pytrace=False)
    return result
