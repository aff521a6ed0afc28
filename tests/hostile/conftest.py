# Fresh throttle counts and a ready simulated robot, as for the command API tests.
from tests.commands.conftest import _fresh_throttle_counts, robot  # noqa: F401
