"""cyborg_audio and cyborg_visual: a text-to-speech queue and sound clip playback with feedback
topics, the microphone (a tone as raw PCM or mp3, with its format latched), the speakers
(recording what operators sent) and the dome lights.

The mp3 microphone encodes with LAME (``lameenc``) as one continuous stream, the way
audio_common's capture node does: chunks do not end on MPEG frame boundaries, and a listener
that subscribes mid-stream gets frames whose bit reservoir points into frames it never saw.
"""

from __future__ import annotations

import asyncio
import base64
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import lameenc
import numpy as np

from ..bus import Bus, SimNode

# --- the microphone and the speakers (raw PCM S16LE, the audio_common formats) ---------------


def tone(freq_hz: float, start: int, count: int, rate: int, amplitude: float = 0.3) -> bytes:
    """``count`` samples of a sine (phase-continuous from sample ``start``) as S16LE bytes."""
    n = np.arange(start, start + count, dtype=np.float64)
    return (np.sin(2 * np.pi * freq_hz * n / rate) * amplitude * 32767).astype("<i2").tobytes()


def dominant_hz(pcm: bytes, rate: int) -> float:
    """The strongest frequency in S16LE samples (0.0 for silence or nothing)."""
    samples = np.frombuffer(pcm[: len(pcm) // 2 * 2], dtype="<i2").astype(np.float64)
    if len(samples) < 2 or not samples.any():
        return 0.0
    spectrum = np.abs(np.fft.rfft(samples * np.hanning(len(samples))))
    spectrum[0] = 0.0
    return float(np.fft.rfftfreq(len(samples), 1.0 / rate)[int(np.argmax(spectrum))])


MIC_CODINGS = ("wave", "mp3")
MP3_KBPS = 32


class Microphone:
    """Publishes a tone in ``chunk_s`` chunks, paced by the clock, while anyone subscribes:
    raw S16LE (``coding="wave"``) or a continuous mp3 stream (``coding="mp3"``)."""

    def __init__(self, publish: Callable[[dict[str, object]], None], wanted: Callable[[], bool], *,
                 freq_hz: float = 440.0, rate: int = 16000, chunk_s: float = 0.02, coding: str = "wave") -> None:
        if coding not in MIC_CODINGS:
            raise ValueError(f"microphone coding must be one of {', '.join(MIC_CODINGS)}; got {coding!r}")
        self.publish, self.wanted = publish, wanted
        self.freq_hz, self.rate, self.chunk = freq_hz, rate, int(rate * chunk_s)
        self.coding = coding
        self.encoder: lameenc.Encoder | None = None
        if coding == "mp3":
            self.encoder = lameenc.Encoder()
            self.encoder.set_bit_rate(MP3_KBPS)
            self.encoder.set_in_sample_rate(rate)
            self.encoder.set_channels(1)
            self.encoder.set_quality(7)  # fast; a tone needs no more
        self.samples = 0  # published so far (the tone's phase)
        self.published = 0

    def info(self) -> dict[str, object]:
        bitrate = MP3_KBPS if self.coding == "mp3" else self.rate * 16
        return {"channels": 1, "sample_rate": self.rate, "sample_format": "S16LE", "bitrate": bitrate,
                "coding_format": self.coding}

    def encode(self, pcm: bytes) -> bytes:
        """One chunk as it goes on the topic (mp3: whatever the encoder has finished, maybe nothing)."""
        return bytes(self.encoder.encode(pcm)) if self.encoder is not None else pcm

    async def run(self) -> None:
        """Publish chunks until cancelled (the node runs it on the bus)."""
        loop = asyncio.get_running_loop()
        period = self.chunk / self.rate
        due = loop.time()
        while True:
            due += period
            await asyncio.sleep(max(0.0, due - loop.time()))
            if loop.time() - due > 1.0:
                due = loop.time()  # the loop stalled: start again rather than burst
            if self.wanted():
                data = self.encode(tone(self.freq_hz, self.samples, self.chunk, self.rate))
                self.samples += self.chunk
                if data:
                    self.published += 1
                    self.publish({"data": base64.b64encode(data).decode()})


@dataclass(frozen=True)
class Heard:
    t: float  # arrival, epoch seconds
    pcm: bytes


class Speaker:
    """What arrived on the speaker topic, kept so tests and benches can measure it."""

    def __init__(self, rate: int = 16000) -> None:
        self.rate = rate
        self.chunks: list[Heard] = []
        self.info: dict[str, object] | None = None

    def on_data(self, msg: dict[str, object]) -> None:
        self.chunks.append(Heard(time.time(), base64.b64decode(str(msg.get("data", "")))))

    def on_info(self, msg: dict[str, object]) -> None:
        self.info = dict(msg)

    def pcm(self) -> bytes:
        return b"".join(c.pcm for c in self.chunks)

    def duration_s(self) -> float:
        return len(self.pcm()) / 2 / self.rate

    def dominant_hz(self) -> float:
        return dominant_hz(self.pcm(), self.rate)

    def gap_s(self, buffer_s: float = 0.06) -> float:
        """Silence a player would leave: it starts ``buffer_s`` after the first chunk, plays every
        chunk in order and waits (a gap) whenever the next has not arrived when the last ends."""
        if not self.chunks:
            return 0.0
        ends = self.chunks[0].t + buffer_s
        gaps = 0.0
        for chunk in self.chunks:
            if chunk.t > ends:
                gaps += chunk.t - ends
                ends = chunk.t
            ends += len(chunk.pcm) / 2 / self.rate
        return gaps


class AudioVisualNode(SimNode):
    """Utterances play one after another; each one is reported (its text) on the feedback topic
    once it has been "spoken", after a time proportional to its length."""

    names = ("/cyborg_audio", "/cyborg_visual")
    publishes = ("tts_feedback", "playback_feedback", "audio", "audio_info")

    def __init__(self, tts_s_per_char: float, tts_min_s: float, clip_s: float, mic_tone_hz: float,
                 mic_coding: str = "wave") -> None:
        self.s_per_char, self.min_s, self.clip_s = tts_s_per_char, tts_min_s, clip_s
        self.queue: asyncio.Queue[str] = asyncio.Queue()
        self.speaking: str | None = None
        self.playing: str | None = None
        self.done_count = 0
        self.mic = Microphone(lambda m: self.bus.publish("audio", m), lambda: self.bus.wants("audio"),
                              freq_hz=mic_tone_hz, coding=mic_coding)
        self.speaker = Speaker()
        self.dome_mode = "default"

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.on("text_to_speech", lambda m: self.say(m["data"]))
        bus.on("playback", self._playback)
        bus.on("domecontrol", self._domecontrol)
        bus.on("speaker", self.speaker.on_data)
        bus.on("speaker_info", self.speaker.on_info)
        bus.spawn(self._speak())
        if self.mic.freq_hz > 0:
            bus.spawn(self.mic.run())
        bus.publish("audio_info", self.mic.info())

    def _playback(self, m: dict[str, Any]) -> None:
        self.bus.rosout(2, "/cyborg_audio", f"Playing sound clip {m['data']}")
        self.play(m["data"])

    def say(self, text: str) -> None:
        self.queue.put_nowait(text)

    def pending(self) -> list[str]:
        queued = list(self.queue._queue)  # type: ignore[attr-defined]  # read-only peek for introspection
        return ([self.speaking] if self.speaking is not None else []) + queued

    def play(self, clip: str) -> None:
        self.playing = clip
        asyncio.get_running_loop().call_later(self.clip_s, self._played, clip)

    def _played(self, clip: str) -> None:
        if self.playing == clip:
            self.playing = None
        self.bus.publish("playback_feedback", {"data": clip})

    async def _speak(self) -> None:
        """Speak what is queued, one utterance after another."""
        while True:
            text = await self.queue.get()
            self.speaking = text
            await asyncio.sleep(max(self.min_s, self.s_per_char * len(text)))
            self.speaking = None
            self.done_count += 1
            self.bus.rosout(2, "/cyborg_audio", f"Finished speaking: {text}")
            self.bus.publish("tts_feedback", {"data": text})

    def _domecontrol(self, m: dict[str, Any]) -> None:
        self.dome_mode = m["data"]
        self.bus.rosout(2, "/cyborg_visual", f"Dome visual mode set to {m['data']}")
