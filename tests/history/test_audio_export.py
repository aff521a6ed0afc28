"""Recorded audio: stored only under a policy, exported as WAV in the recorded format."""

import asyncio
import base64
import io
import json
import time
import wave

import numpy as np
import pytest
from asgiref.sync import sync_to_async

from history.defaults import ensure_default_policies
from history.models import Mode, Sample, TopicPolicy
from history.policies import policies_add_discovered, policy_upsert
from history.storage import write_rows
from robot import interface as ri
from simulator.nodes.audiovisual import tone
from tests.helpers import async_wait_until

from .test_api import _content

pytestmark = pytest.mark.postgres  # the history store: its writes, queries and rollups differ by engine

AUDIO = "audio_common_msgs/AudioData"
INFO = "audio_common_msgs/AudioInfo"
EXPORT = "/api/history/export/"


def _dominant_hz(frames: bytes, rate: int, channels: int) -> float:
    samples = np.frombuffer(frames, dtype="<i2").reshape(-1, channels)[:, 0].astype(float)
    spectrum = np.abs(np.fft.rfft(samples * np.hanning(len(samples))))
    return float(np.fft.rfftfreq(len(samples), 1 / rate)[int(np.argmax(spectrum))])


def _info(rate: int = 16000, channels: int = 1, coding: str = "wave") -> str:
    return json.dumps({"channels": channels, "sample_rate": rate, "sample_format": "S16LE",
                       "bitrate": rate * 16 * channels, "coding_format": coding})


def _record_tone(topic: str, *, rate: int, channels: int = 1, seconds: float = 1.0, hz: float = 440.0,
                 t0: float | None = None, info: str | None = None) -> float:
    """Write a tone as 20 ms AudioData chunks (out of order, to prove the export sorts), after its AudioInfo."""
    t0 = t0 or time.time() - 600
    chunk = rate // 50
    rows = [(f"{topic}_info", INFO, t0 - 5, info or _info(rate, channels))]
    for i in range(int(seconds * 50)):
        mono = np.frombuffer(tone(hz, i * chunk, chunk, rate), dtype="<i2")
        pcm = np.repeat(mono, channels).astype("<i2").tobytes()
        rows.append((topic, AUDIO, t0 + i * 0.02, json.dumps({"data": base64.b64encode(pcm).decode()})))
    write_rows(rows[:1] + rows[1:][::-1])
    return t0


def _wav(res) -> wave.Wave_read:
    assert res.status_code == 200, res.content
    assert res["Content-Type"] == "audio/wav"
    assert res["Content-Disposition"].endswith('.wav"')
    return wave.open(io.BytesIO(_content(res)))


@pytest.mark.parametrize("rate, channels", [(16000, 1), (22050, 2)])
def test_it_exports_recorded_audio_as_wav_in_the_recorded_format(operator_api, rate, channels):
    topic = "/history_test/mic"
    t0 = _record_tone(topic, rate=rate, channels=channels, seconds=1.0)

    res = operator_api.get(EXPORT, {"topic": topic, "start": t0, "end": t0 + 60, "format": "wav"})

    with _wav(res) as wav:
        assert (wav.getframerate(), wav.getnchannels(), wav.getsampwidth()) == (rate, channels, 2)
        assert wav.getnframes() / rate == pytest.approx(1.0, abs=0.001)
        frames = wav.readframes(wav.getnframes())
    assert _dominant_hz(frames, rate, channels) == pytest.approx(440, abs=5)
    # In time order: the whole second is one continuous tone (no phase jumps between chunks).
    expected = np.repeat(np.frombuffer(tone(440, 0, rate, rate), dtype="<i2"), channels)
    assert np.array_equal(np.frombuffer(frames, dtype="<i2"), expected[:len(frames) // 2])


def test_it_exports_only_the_requested_range(operator_api):
    topic = "/history_test/mic"
    t0 = _record_tone(topic, rate=16000, seconds=2.0)

    res = operator_api.get(EXPORT, {"topic": topic, "start": t0 + 0.5 - 0.001, "end": t0 + 1.5 - 0.001,
                                  "format": "wav"})

    with _wav(res) as wav:
        assert wav.getnframes() == 50 * 320


def test_it_exports_speaker_audio_in_the_declared_speaker_format_without_a_recorded_info(operator_api):
    topic = ri.topic("speaker").name
    t0 = time.time() - 600
    write_rows([(topic, AUDIO, t0 + i * 0.02, json.dumps({"data": base64.b64encode(tone(440, i * 320, 320, 16000))
                                                                      .decode()})) for i in range(25)])

    res = operator_api.get(EXPORT, {"topic": topic, "start": t0, "end": t0 + 60, "format": "wav"})

    with _wav(res) as wav:
        assert (wav.getframerate(), wav.getnchannels(), wav.getnframes()) == (16000, 1, 25 * 320)


def test_it_exports_an_empty_audio_range_as_a_valid_empty_wav(operator_api):
    TopicPolicy.objects.create(topic=ri.topic("audio").name, msg_type=AUDIO, mode=Mode.EVERY)

    res = operator_api.get(EXPORT, {"topic": ri.topic("audio").name, "format": "wav"})

    with _wav(res) as wav:
        assert (wav.getframerate(), wav.getnchannels(), wav.getnframes()) == (16000, 1, 0)


def test_it_refuses_wav_for_a_topic_that_is_not_audio(operator_api):
    write_rows([("/history_test/api", "std_msgs/String", time.time() - 60, json.dumps({"data": "hi"}))])

    res = operator_api.get(EXPORT, {"topic": "/history_test/api", "format": "wav"})

    assert res.status_code == 400
    body = res.json()
    assert body["field"] == "format"
    assert "audio_common_msgs/AudioData" in body["detail"] and "std_msgs/String" in body["detail"]


def test_it_refuses_wav_for_mp3_audio(operator_api):
    topic = "/history_test/mic"
    t0 = _record_tone(topic, rate=16000, seconds=0.2, info=_info(coding="mp3"))

    res = operator_api.get(EXPORT, {"topic": topic, "start": t0, "end": t0 + 60, "format": "wav"})

    assert res.status_code == 400
    assert res.json()["field"] == "format"
    assert "mp3" in res.json()["detail"]


def test_no_default_policy_and_no_discovery_records_audio(db):
    ensure_default_policies()
    added = policies_add_discovered(topics=[(ri.topic("audio").name, AUDIO), ("/other", "std_msgs/String")],
                                    mode=Mode.EVERY)

    assert ri.topic("audio").name in added
    assert not TopicPolicy.objects.filter(msg_type=AUDIO).exclude(mode=Mode.OFF).exists()
    assert TopicPolicy.objects.get(topic="/other").mode == Mode.EVERY


async def _stored(topic: str, n: int) -> None:
    count = sync_to_async(lambda: Sample.objects.filter(topic=topic).count())
    deadline = time.monotonic() + 20
    while await count() < n:
        assert time.monotonic() < deadline, f"fewer than {n} chunks of {topic} stored after 20 s"
        await asyncio.sleep(0.05)


async def _settled(topic: str) -> None:
    """Wait until the recorder's last batches of ``topic`` are written (the count stops moving)."""
    count = sync_to_async(lambda: Sample.objects.filter(topic=topic).count())
    last, deadline = -1, time.monotonic() + 10
    while (now := await count()) != last:
        assert time.monotonic() < deadline, "the recorder kept writing after the policy was switched off"
        last = now
        await asyncio.sleep(0.3)


@pytest.mark.django_db(transaction=True)
async def test_it_records_the_microphone_only_under_a_policy_and_exports_it_as_wav(recording, sim, link,
                                                                                   operator_api):
    mic = ri.topic("audio").name
    await sync_to_async(ensure_default_policies)()
    await async_wait_until(lambda: sim.subscription_count(ri.topic("battery_soc").name) > 0, timeout=10,
                           what="the recorder following the default policies")
    assert sim.subscription_count(mic) == 0
    assert sim.robot.av_node.mic.published == 0

    await sync_to_async(policy_upsert)(topic=mic, msg_type=AUDIO, mode=Mode.EVERY)
    await _stored(mic, 50)  # a second of audio
    await sync_to_async(policy_upsert)(topic=mic, mode=Mode.OFF)
    await async_wait_until(lambda: sim.subscription_count(mic) == 0, timeout=10, what="the recorder letting go")
    await _settled(mic)

    rows = await sync_to_async(lambda: list(
        Sample.objects.filter(topic=mic).order_by("received_at").values_list("received_at", flat=True)))()

    def export() -> tuple[int, int, int, bytes]:
        with _wav(operator_api.get(EXPORT, {"topic": mic, "format": "wav"})) as wav:
            return wav.getframerate(), wav.getnchannels(), wav.getnframes(), wav.readframes(wav.getnframes())

    rate, channels, nframes, frames = await sync_to_async(export)()
    assert (rate, channels) == (16000, 1)  # the latched AudioInfo's
    assert nframes == len(rows) * 320  # every stored 20 ms chunk, whole
    # Nothing the recorder took was lost on the way to the file.
    assert (recording.dropped, recording.oversize) == (0, 0)
    assert 50 <= len(rows) <= sim.robot.av_node.mic.published
    assert _dominant_hz(frames, 16000, 1) == pytest.approx(440, abs=5)


@pytest.mark.django_db(transaction=True)
async def test_listening_and_talking_store_no_audio_without_a_recording_policy(recording, sim, link, operator):
    from tests.audio.support import TALK, audio_socket, kind, talk_tone

    mic, speaker = ri.topic("audio").name, ri.topic("speaker").name
    await sync_to_async(ensure_default_policies)()
    await async_wait_until(lambda: sim.subscription_count(ri.topic("battery_soc").name) > 0, timeout=10,
                           what="the recorder following the default policies")
    ears = await audio_socket(operator)
    await ears.send({"type": "listen", "on": True})
    await ears.chunk_count(25)  # half a second heard
    await ears.send(TALK)
    await ears.text(kind("talking", on=True))
    await talk_tone(ears, 500, 0.5)
    await async_wait_until(lambda: len(sim.robot.av_node.speaker.chunks) >= 25, what="the talk at the robot")
    await ears.send({"type": "talk", "on": False})
    await ears.text(kind("talking", on=False))
    await ears.close()
    await recording.flush()
    assert recording.offer in link.listeners and recording.every  # it saw every message, recording others
    stored = await sync_to_async(lambda: Sample.objects.filter(topic__in=[mic, speaker]).count())()
    assert stored == 0
