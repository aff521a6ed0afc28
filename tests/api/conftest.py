# The commanding fixtures (fresh throttle counts, a ready simulated robot) serve the API tests too.
from tests.api.token_cache import empty_token_cache  # noqa: F401
from tests.commands.conftest import _fresh_throttle_counts, robot  # noqa: F401
