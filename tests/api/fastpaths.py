"""What the fast paths' tests share: an empty token cache, and a spy on what a fast path passes on."""

from __future__ import annotations

from typing import Any

import pytest

from robot.api.tokens import CachedTokenAuthentication


@pytest.fixture
def empty_token_cache():
    CachedTokenAuthentication._cache.clear()
    yield
    CachedTokenAuthentication._cache.clear()


def spy_on_passed_on(monkeypatch, app_class: type, attribute: str) -> list[str]:
    """The paths of the requests the site's ``app_class`` hands to its ``attribute`` (the app behind it)."""
    from server.asgi import application

    app = application.application_mapping["http"]
    while not isinstance(app, app_class):  # under the request counter (cyborg_site.drain)
        app = app.app
    calls: list[str] = []
    real = getattr(app, attribute)

    class Spy:
        send_response = getattr(real, "send_response", None)

        async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
            calls.append(scope["path"])
            await real(scope, receive, send)

    monkeypatch.setattr(app, attribute, Spy())
    return calls
