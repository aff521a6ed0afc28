"""An empty per-process token cache, for tests that count queries or revoke tokens."""

from __future__ import annotations

import pytest

from robot.api.tokens import CachedTokenAuthentication


@pytest.fixture
def empty_token_cache():
    CachedTokenAuthentication._cache.clear()
    yield
    CachedTokenAuthentication._cache.clear()
