"""Listening to a robot whose microphone sends mp3: pages get PCM of the robot's tone, decoded
once in the link; audio that does not decode, or a format nobody can play, is said to the
listener instead of going silent."""

from __future__ import annotations

import base64

import pytest

from robot import interface as ri
from robot.audio.mic import MAX_UNFRAMED
from robot.live.state import get_store
from simulator.nodes.audiovisual import dominant_hz
from tests.audio.support import audio_socket, kind
from tests.helpers import async_wait_until

pytestmark = pytest.mark.django_db(transaction=True)
MIC = ri.topic("audio").name


@pytest.fixture
def sim(request):
    """A simulated robot whose microphone sends an mp3 stream (a 440 Hz tone unless the test's
    ``mic_tone_hz`` parameter says otherwise; 0 is silent, for tests that publish their own)."""
    from simulator.harness import SimThread

    freq = getattr(request, "param", 440.0)
    with SimThread(port=0, video_port=0, startup_s=0.5, mic_coding="mp3", mic_tone_hz=freq) as running:
        yield running


def declared_coding() -> str | None:
    """The microphone coding the link last heard the robot declare (its latched audio_info)."""
    return ((get_store().get_all().get("audio_info") or {}).get("msg") or {}).get("coding_format")


async def test_an_mp3_microphone_reaches_listeners_as_pcm_of_its_tone(link, sim, operator, admin_user):
    # Until this robot's audio_info arrives, the store may hold none or an earlier robot's (the services
    # pass shares one Redis): listening then starts on that format and the mp3 one follows.
    await async_wait_until(lambda: declared_coding() == "mp3", timeout=10, interval=0.1,
                           what="the robot's mp3 audio_info heard")
    ears, more = await audio_socket(operator), await audio_socket(admin_user)
    for socket in (ears, more):
        await socket.send({"type": "listen", "on": True})
    fmt = await ears.text(kind("format"))
    assert fmt["coding_format"] == "wave" and fmt["sample_format"] == "S16LE"
    assert (fmt["robot_coding_format"], fmt["sample_rate"], fmt["channels"]) == ("mp3", 16000, 1)
    for socket in (ears, more):
        await socket.text(kind("listening", on=True))
        await socket.chunk_count(30)
    pcm = b"".join(ears.chunks)
    assert len(pcm) / 2 / 16000 > 0.5
    assert dominant_hz(pcm[4000:], 16000) == pytest.approx(440, abs=5)
    # One decode, shared: the same PCM, though the second listener's first chunk may be a later one
    # (scaled, each socket's listen reaches the relay in its own time).
    theirs = b"".join(more.chunks)
    assert theirs[:4000] in pcm or pcm[:4000] in theirs
    assert sim.subscription_count(MIC) == 1
    await ears.close()
    await more.close()


@pytest.mark.parametrize("sim", [0.0], indirect=True)
async def test_microphone_audio_that_does_not_decode_is_reported_to_listeners(link, sim, operator):
    ears = await audio_socket(operator)
    await ears.send({"type": "listen", "on": True})
    await ears.text(kind("listening", on=True))
    await async_wait_until(lambda: sim.subscription_count(MIC) == 1, what="microphone subscribed")
    noise = {"data": base64.b64encode(bytes(1000)).decode()}
    sim.call(lambda: sim.robot.publish_external(MIC, noise, count=MAX_UNFRAMED // 1000 + 2))
    problem = await ears.text(kind("error", code="mic"))
    assert "could not be decoded" in problem["message"] and "no mp3 frame" in problem["message"]
    assert ears.chunks == []
    await ears.close()


async def test_a_new_microphone_format_reaches_pages_already_listening(link, sim, operator):
    ears = await audio_socket(operator)
    await ears.send({"type": "listen", "on": True})
    assert (await ears.text(kind("format")))["sample_rate"] == 16000
    await ears.chunk_count(10)
    info = {"channels": 1, "sample_rate": 24000, "sample_format": "S16LE", "bitrate": 32, "coding_format": "mp3"}
    sim.call(lambda: sim.robot.publish_external(ri.topic("audio_info").name, info))
    fmt = await ears.text(kind("format"))
    assert (fmt["sample_rate"], fmt["robot_coding_format"], fmt["coding_format"]) == (24000, "mp3", "wave")
    count = len(ears.chunks)
    await ears.chunk_count(count + 20)
    # the simulator still sends 16 kHz mp3: the link now resamples it to the declared 24 kHz
    assert dominant_hz(b"".join(ears.chunks[count + 5:]), 24000) == pytest.approx(440, abs=5)
    await ears.close()


@pytest.mark.parametrize("sim", [0.0], indirect=True)
async def test_listening_to_a_microphone_format_nobody_can_play_is_refused_with_the_reason(link, sim, operator):
    info = {"channels": 1, "sample_rate": 48000, "sample_format": "S16LE", "bitrate": 64, "coding_format": "opus"}
    sim.call(lambda: sim.robot.publish_external(ri.topic("audio_info").name, info))
    from robot.live.state import get_store

    def opus_known() -> bool:
        entry = get_store().get_all().get("audio_info") or {}
        return entry.get("msg", {}).get("coding_format") == "opus"

    await async_wait_until(opus_known, what="the link stored the new format")
    ears = await audio_socket(operator)
    await ears.send({"type": "listen", "on": True})
    refusal = await ears.text(kind("error"))
    assert refusal["code"] == "invalid" and "sends opus" in refusal["message"]
    assert sim.subscription_count(MIC) == 0
    await ears.close()
