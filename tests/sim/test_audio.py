"""The simulated microphone and speakers, driven by unmodified roslibpy."""

from __future__ import annotations

import base64
import io
import time

import av
import numpy as np
import pytest
import roslibpy

from robot import interface as ri
from simulator.harness import SimThread
from simulator.nodes.audiovisual import Heard, Speaker, dominant_hz, tone
from tests.helpers import wait_until
from tests.sim.support import FAST, Inbox


def _topic(ros, key: str) -> roslibpy.Topic:
    t = ri.topic(key)
    return roslibpy.Topic(ros, t.name, t.type)


def test_the_microphone_publishes_its_tone_and_latched_format_only_while_someone_listens(sim, ros):
    info, mic = Inbox(), Inbox()
    _topic(ros, "audio_info").subscribe(info)
    info.wait(what="audio_info")
    assert info.items[0]["sample_rate"] == 16000 and info.items[0]["coding_format"] == "wave"
    assert sim.robot.av_node.mic.published == 0
    topic = _topic(ros, "audio")
    topic.subscribe(mic)
    mic.wait(lambda items: len(items) >= 25, what="half a second of microphone")
    pcm = b"".join(base64.b64decode(m["data"]) for m in mic.items)
    assert len(base64.b64decode(mic.items[0]["data"])) == 640  # 20 ms of 16 kHz S16LE
    assert abs(dominant_hz(pcm, 16000) - 440) < 5
    topic.unsubscribe()
    wait_until(lambda: sim.subscription_count(ri.topic("audio").name) == 0)
    published = sim.robot.av_node.mic.published
    time.sleep(0.1)
    assert sim.robot.av_node.mic.published == published


def test_an_mp3_microphone_publishes_one_continuous_mp3_stream_of_its_tone():
    with SimThread(**FAST, mic_coding="mp3") as sim:
        ros = roslibpy.Ros(sim.host, sim.port)
        ros.run(timeout=10)
        try:
            info, mic = Inbox(), Inbox()
            _topic(ros, "audio_info").subscribe(info)
            info.wait(what="audio_info")
            assert info.items[0]["coding_format"] == "mp3" and info.items[0]["sample_rate"] == 16000
            _topic(ros, "audio").subscribe(mic)
            mic.wait(lambda items: len(items) >= 40, what="a second of mp3 microphone")
        finally:
            ros.close()
    stream = b"".join(base64.b64decode(m["data"]) for m in mic.items)
    # Read back as a file by FFmpeg's own demuxer: the chunks join into one valid mp3 stream.
    with av.open(io.BytesIO(stream), format="mp3") as container:
        pcm = b"".join(frame.to_ndarray().astype("<f4").tobytes() for frame in container.decode(audio=0))
    samples = (np.frombuffer(pcm, "<f4") * 32767).astype("<i2").tobytes()
    assert len(samples) / 2 / 16000 > 0.5
    assert abs(dominant_hz(samples, 16000) - 440) < 5
    assert {len(base64.b64decode(m["data"])) for m in mic.items} != {144}  # not cut at frame boundaries


def test_the_speakers_keep_what_arrives_for_measuring(sim, ros):
    _topic(ros, "speaker_info").publish(roslibpy.Message(ri.speaker_info()))
    speaker = _topic(ros, "speaker")
    for i in range(25):
        data = tone(1000, i * 320, 320, 16000)
        speaker.publish(roslibpy.Message({"data": base64.b64encode(data).decode()}))
        time.sleep(0.02)
    wait_until(lambda: len(sim.robot.av_node.speaker.chunks) == 25)
    heard = sim.robot.av_node.speaker
    assert heard.info == ri.speaker_info()
    assert abs(heard.duration_s() - 0.5) < 1e-9
    assert abs(heard.dominant_hz() - 1000) < 5


def test_gaps_are_the_silence_a_player_with_a_buffer_would_leave():
    speaker = Speaker()
    chunk = bytes(640)  # 20 ms
    # on time, on time, 50 ms late (30 ms after the buffered audio ran out), then on time again
    for t in (0.0, 0.02, 0.11, 0.13):
        speaker.chunks.append(Heard(100 + t, chunk))
    assert speaker.gap_s(buffer_s=0.04) == pytest.approx(0.03)
    assert speaker.gap_s(buffer_s=0.1) == 0.0
