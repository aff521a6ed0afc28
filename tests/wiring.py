"""Which tests depend on the wiring, and so run in both passes (embedded, then PostgreSQL + Redis).

Both wirings run the same Redis code (the embedded default on a private server of each process), so
what differs is the database engine and the topology: a test depends on the wiring when it uses the
database (the ``db`` fixture, a ``django_db`` or ``postgres`` mark) or the scaled wiring as processes
sharing a Redis (a ``redis`` or ``stack`` mark). Everything else runs in the embedded pass only.
"""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

WIRING = "wiring"
WIRING_MARKS = frozenset({WIRING, "django_db", "redis", "postgres", "stack"})
WIRING_FIXTURES = frozenset({"db", "transactional_db", "live_server"})


def depends_on_wiring(item: pytest.Item) -> bool:
    if any(item.get_closest_marker(name) is not None for name in WIRING_MARKS):
        return True
    return bool(WIRING_FIXTURES & set(getattr(item, "fixturenames", ())))


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", f"{WIRING}: depends on the database engine or on the scaled wiring "
                                       "(runs in both passes; most tests get it from their fixtures)")


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
