"""The microphone as pages play it: mp3 decoded from a continuous stream cut anywhere, raw
PCM kept in whole samples, formats that cannot be played refused with a reason."""

from __future__ import annotations

import random

import pytest

from robot.audio.mic import (
    DecodeError,
    Mp3Decoder,
    PcmRelay,
    Unplayable,
    decoder_for,
    layer3_frame_size,
    playback_format,
)
from simulator.nodes.audiovisual import Microphone, dominant_hz, tone

MP3_INFO = {"channels": 1, "sample_rate": 16000, "sample_format": "S16LE", "bitrate": 32, "coding_format": "mp3"}


def mp3_stream(seconds: float, freq_hz: float = 440.0) -> bytes:
    """What the simulator's mp3 microphone sends (LAME), as one byte string."""
    mic = Microphone(lambda _m: None, lambda: True, coding="mp3", freq_hz=freq_hz)
    return b"".join(mic.encode(tone(freq_hz, i * 320, 320, 16000)) for i in range(round(seconds / 0.02)))


def cut(data: bytes, seed: int = 1) -> list[bytes]:
    rng = random.Random(seed)
    pieces, i = [], 0
    while i < len(data):
        n = rng.randint(1, 300)
        pieces.append(data[i:i + n])
        i += n
    return pieces


def test_an_mp3_stream_cut_anywhere_decodes_to_its_tone_at_the_declared_format():
    stream = mp3_stream(2.0)
    decoder = decoder_for(MP3_INFO)
    assert isinstance(decoder, Mp3Decoder)
    pcm = b"".join(decoder.feed(piece) for piece in cut(stream))
    assert 1.8 < len(pcm) / 2 / 16000 <= 2.0
    assert dominant_hz(pcm, 16000) == pytest.approx(440, abs=5)


def test_joining_an_mp3_stream_mid_way_decodes_from_the_next_frames():
    stream = mp3_stream(2.0, freq_hz=1000)
    pcm = Mp3Decoder(1, 16000).feed(stream[1001:])  # mid-frame, its reservoir never seen
    assert len(pcm) / 2 / 16000 > 1.5  # 2 s less the quarter second skipped
    assert dominant_hz(pcm, 16000) == pytest.approx(1000, abs=5)


def test_joining_at_any_chunk_of_a_live_stream_finds_the_real_frames():
    """Torn frames hold byte patterns that pass for headers (one decodes as 48 kHz stereo):
    the decoder must not be fooled into that, wherever it joins."""
    mic = Microphone(lambda _m: None, lambda: True, coding="mp3", freq_hz=440)
    chunks = [mic.encode(tone(440, i * 320, 320, 16000)) for i in range(400)]
    for start in range(0, 300, 7):
        decoder = Mp3Decoder(1, 16000)
        pcm = b"".join(decoder.feed(chunk) for chunk in chunks[start:start + 60])
        assert len(pcm) / 2 / 16000 > 0.9, start
        assert dominant_hz(pcm, 16000) == pytest.approx(440, abs=5), start
        assert decoder.source is not None and decoder.source[1:] == ("mono", 16000), start


def test_mp3_resampled_to_the_declared_rate():
    pcm = decoder_for({**MP3_INFO, "sample_rate": 48000}).feed(mp3_stream(1.0))
    assert len(pcm) / 2 / 48000 > 0.8
    assert dominant_hz(pcm, 48000) == pytest.approx(440, abs=5)


def test_bytes_that_are_not_mp3_raise_a_decode_error():
    decoder = Mp3Decoder(1, 16000)
    with pytest.raises(DecodeError, match="no mp3 frame"):
        for _ in range(10):
            decoder.feed(bytes(1000))
    assert decoder.feed(mp3_stream(0.5))  # and it carries on with real mp3


def test_corrupt_frames_after_the_start_raise_a_decode_error():
    stream = bytearray(mp3_stream(1.0))
    decoder = Mp3Decoder(1, 16000)
    assert decoder.feed(bytes(stream[: len(stream) // 2]))
    # a valid header with a body of noise where the side information says impossible things
    size = layer3_frame_size(stream, 0)
    header = bytes(stream[:4])
    with pytest.raises(DecodeError, match="did not decode"):
        for seed in range(20):
            body = random.Random(seed).randbytes(size - 4)
            decoder.feed(header + body)


def test_layer3_frame_sizes_follow_the_header():
    assert layer3_frame_size(bytes.fromhex("fff3 4800"), 0) == 144  # MPEG-2, 32 kbps, 16 kHz
    assert layer3_frame_size(bytes.fromhex("fffb 9064"), 0) == 144 * 128000 // 44100 + 0  # MPEG-1, 128 kbps
    assert layer3_frame_size(bytes.fromhex("fffb 9264"), 0) == 144 * 128000 // 44100 + 1  # padded
    assert layer3_frame_size(bytes.fromhex("fffd 9064"), 0) == 0  # Layer II
    assert layer3_frame_size(bytes.fromhex("fffb f064"), 0) == 0  # bad bitrate
    assert layer3_frame_size(bytes.fromhex("00fb 9064"), 0) == 0  # no sync


def test_raw_pcm_passes_in_whole_sample_frames():
    relay = decoder_for({"coding_format": "wave", "channels": 2, "sample_rate": 16000, "sample_format": "S16LE"})
    assert isinstance(relay, PcmRelay)
    assert relay.feed(b"abcdef") == b"abcd"
    assert relay.feed(b"gh") == b"efgh"


def test_pages_are_told_pcm_whatever_the_robot_sends():
    assert playback_format(MP3_INFO) == {"channels": 1, "sample_rate": 16000, "sample_format": "S16LE",
                                         "coding_format": "wave", "robot_coding_format": "mp3"}
    assert playback_format(None)["robot_coding_format"] == "wave"


@pytest.mark.parametrize("info, says", [
    ({"coding_format": "opus"}, "sends opus"),
    ({"coding_format": "wave", "sample_format": "F32LE"}, "F32LE"),
    ({"coding_format": "mp3", "channels": 6}, "6 channels"),
    ({"coding_format": "wave", "sample_rate": 2000}, "2000 Hz"),
    ({"coding_format": "wave", "sample_rate": "fast"}, "unreadable"),
])
def test_formats_that_cannot_be_played_are_refused_with_the_reason(info, says):
    with pytest.raises(Unplayable, match=says):
        playback_format(info)
