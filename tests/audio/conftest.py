import pytest


@pytest.fixture(autouse=True)
def _free_talk_lock(settings):
    """Every test starts with nobody talking (the Redis lock outlives a test otherwise)."""
    from robot.audio.talk import reset_talk_lock

    def clear():
        reset_talk_lock()
        if settings.REDIS_URL:
            import redis

            from robot.live.state import redis_key

            redis.Redis.from_url(settings.REDIS_URL).delete(redis_key("talk-lock"))

    clear()
    yield
    clear()


@pytest.fixture(autouse=True)
def _patient_quiet_cut(settings):
    """A loaded test machine can stall a test's sender longer than the real quiet cut; only the
    test of that cut uses the real setting."""
    settings.AUDIO_TALK_QUIET_S = 2.0
