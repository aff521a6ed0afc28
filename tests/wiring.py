"""Which tests run in the services pass (PostgreSQL + the machine's Redis) as well as in the embedded one.

Both wirings run the same Redis code (the embedded default on a private server of each process), so
a test depends on the wiring only where what it shows depends on the database engine or on processes
sharing one Redis. The rule is an explicit mark, on the test or on its module (``pytestmark``):

- ``postgres``: its behaviour depends on the engine: the history store (its writes, raw SQL, rollups
  and time queries, retention's deletes, incidents' row locks, the Celery worker that writes them),
  the audit writer's own long-lived connection, a database that goes down, text an engine refuses.
  A test that merely stores a user or a row through the ORM is not marked: SQLite shows it as well.
- ``redis``: the scaled wiring, processes sharing a Redis (most skip themselves in the embedded pass).
- ``stack``: the production topology (a part of the suite of its own).

Every other test runs in the embedded pass only, which runs every test that does not skip itself
there; a test that skips itself in the embedded pass without one of these marks would run in no pass,
so it fails instead.
"""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

WIRING = "wiring"
WIRING_MARKS = frozenset({"postgres", "redis", "stack"})


def depends_on_wiring(item: pytest.Item) -> bool:
    return any(item.get_closest_marker(name) is not None for name in WIRING_MARKS)


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", f"{WIRING}: set from the postgres, redis and stack marks (tests/wiring.py); "
                                       "the services pass runs these")


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
                           "marked postgres, redis or stack: it would run in no pass")
    return report
