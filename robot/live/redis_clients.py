"""Every Redis client of the product comes from here, so each behaves the same when Redis
restarts or freezes:

- a command gives up after ``COMMAND_TIMEOUT_S`` (redis-py's own default waits 5 s and tries
  three more times with backoff: a frozen Redis held a request for 20 s);
- a pooled connection idle for ``HEALTH_CHECK_S`` is pinged before it is used, and a command
  that meets a broken connection (Redis restarted under it) is tried once more on a fresh one,
  so the first request after a restart works; a timeout is never retried;
- an asyncio client belongs to the event loop that first used it: one per loop and URL.

Blocking reads (a list pop, a pub/sub subscription) ask for a longer socket timeout.
In the embedded default the configured Redis is the process's private server, started here on first
use (robot.live.private_server).
"""

from __future__ import annotations

import asyncio
import threading
import weakref
from typing import Any

from django.conf import settings

from robot.live import private_server

COMMAND_TIMEOUT_S = 1.0
CONNECT_TIMEOUT_S = 0.5
HEALTH_CHECK_S = 2

_aclients: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, dict[tuple[str, float | None], Any]] = (
    weakref.WeakKeyDictionary())
_clients: dict[str, Any] = {}
_lock = threading.Lock()


def _options(asyncio_client: bool, **overrides: Any) -> dict[str, Any]:
    from redis.backoff import NoBackoff
    from redis.exceptions import ConnectionError as RedisConnectionError

    if asyncio_client:
        from redis.asyncio.retry import Retry
    else:
        from redis.retry import Retry  # type: ignore[assignment]
    return {
        "socket_timeout": COMMAND_TIMEOUT_S, "socket_connect_timeout": CONNECT_TIMEOUT_S,
        "health_check_interval": HEALTH_CHECK_S,
        "retry": Retry(NoBackoff(), 1, supported_errors=(RedisConnectionError,)),
        **overrides,
    }


def aclient(url: str | None = None, *, blocking_s: float | None = None) -> Any:
    """This loop's asyncio client for ``url`` (the configured Redis by default); ``blocking_s``:
    the longest a blocking read on it waits."""
    import redis.asyncio

    url = _started(url)
    per_loop = _aclients.setdefault(asyncio.get_running_loop(), {})
    client = per_loop.get((url, blocking_s))
    if client is None:
        timeout = COMMAND_TIMEOUT_S if blocking_s is None else blocking_s + COMMAND_TIMEOUT_S
        client = per_loop[(url, blocking_s)] = redis.asyncio.Redis.from_url(
            url, **_options(True, socket_timeout=timeout))
    return client


def client(url: str | None = None) -> Any:
    """The process's client for synchronous code (its pool is shared by threads)."""
    import redis

    url = _started(url)
    with _lock:
        found = _clients.get(url)
        if found is None:
            found = _clients[url] = redis.Redis.from_url(url, **_options(False))
        return found


def new_aclient(url: str | None = None, **overrides: Any) -> Any:
    """A client of its own (the caller closes it): the link's lease, which times out with its lease,
    and the live feed's subscription, which waits for messages as long as there are none."""
    import redis.asyncio

    return redis.asyncio.Redis.from_url(_started(url), **_options(True, **overrides))


def _started(url: str | None) -> str:
    url = url or settings.REDIS_URL
    private_server.ensure(url)
    return url
