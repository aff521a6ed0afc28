"""Fixtures for the simulator's own tests: a fast-timing SimThread, roslibpy and raw websocket clients."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest
import roslibpy

from simulator.harness import SimThread
from tests.sim.support import FAST, Raw


@pytest.fixture
def sim() -> Iterator[SimThread]:
    """A simulated Cyborg with short state timers, on free ports, in a thread of its own."""
    with SimThread(**FAST) as running:
        yield running


@pytest.fixture
def ros(sim: SimThread) -> Iterator[roslibpy.Ros]:
    client = roslibpy.Ros(sim.host, sim.port)
    client.run(timeout=10)
    yield client
    client.close()


@pytest.fixture
def raw_client(sim: SimThread) -> Iterator[Callable[[], Raw]]:
    clients: list[Raw] = []

    def make() -> Raw:
        clients.append(Raw(sim.url))
        return clients[-1]

    yield make
    for c in clients:
        c.close()

