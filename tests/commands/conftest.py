import pytest


@pytest.fixture(autouse=True)
def _fresh_throttle_counts():
    """DRF keeps throttle history in the cache; every test starts with none."""
    from django.core.cache import cache

    cache.clear()
    yield
    cache.clear()


@pytest.fixture
def robot(sim, link_thread):
    """The simulator, connected through the link, with startup finished."""
    from tests.commands.support import wait_ready, wait_server_ready

    wait_ready(sim)
    wait_server_ready()
    return sim

