import pytest


@pytest.fixture(autouse=True)
def _free_drive_lock(settings):
    """Every test starts with nobody driving (the Redis lock outlives a test otherwise)."""
    from robot.teleop.lock import reset_lock

    def clear():
        reset_lock()
        from robot.live import redis_clients
        from robot.live.state import redis_key

        redis_clients.client().delete(redis_key("teleop-lock"))

    clear()
    yield
    clear()
