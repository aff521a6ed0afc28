import pytest


@pytest.fixture(autouse=True)
def _free_talk_lock(settings):
    """Every test starts with nobody talking (the Redis lock outlives a test otherwise)."""
    from robot.audio.talk import reset_talk_lock

    def clear():
        reset_talk_lock()
        from robot.live import redis_clients
        from robot.live.state import redis_key

        redis_clients.client().delete(redis_key("talk-lock"))

    clear()
    yield
    clear()


@pytest.fixture(autouse=True)
def _patient_quiet_cut(settings):
    """A loaded test machine can stall a test's sender longer than the real quiet cut; only the
    test of that cut uses the real setting."""
    settings.AUDIO_TALK_QUIET_S = 2.0
