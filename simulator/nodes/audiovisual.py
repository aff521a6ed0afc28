"""cyborg_audio and cyborg_visual: speech, sound clips, the microphone, the speaker and the dome lights."""

from __future__ import annotations

from typing import Any

from ..audio import Audio, Microphone, Speaker
from ..bus import Bus, SimNode


class AudioVisualNode(SimNode):
    names = ("/cyborg_audio", "/cyborg_visual")
    publishes = ("tts_feedback", "playback_feedback", "audio", "audio_info")

    def __init__(self, tts_s_per_char: float, tts_min_s: float, clip_s: float, mic_tone_hz: float,
                 mic_coding: str = "wave") -> None:
        self.audio = Audio(self._on_spoken, lambda clip: self.bus.publish("playback_feedback", {"data": clip}),
                           tts_s_per_char, tts_min_s, clip_s)
        self.mic = Microphone(lambda m: self.bus.publish("audio", m), lambda: self.bus.wants("audio"),
                              freq_hz=mic_tone_hz, coding=mic_coding)
        self.speaker = Speaker()
        self.dome_mode = "default"

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.on("text_to_speech", lambda m: self.audio.say(m["data"]))
        bus.on("playback", self._playback)
        bus.on("domecontrol", self._domecontrol)
        bus.on("speaker", self.speaker.on_data)
        bus.on("speaker_info", self.speaker.on_info)
        bus.spawn(self.audio.run())
        if self.mic.freq_hz > 0:
            bus.spawn(self.mic.run())
        bus.publish("audio_info", self.mic.info())

    def _playback(self, m: dict[str, Any]) -> None:
        self.bus.rosout(2, "/cyborg_audio", f"Playing sound clip {m['data']}")
        self.audio.play(m["data"])

    def _domecontrol(self, m: dict[str, Any]) -> None:
        self.dome_mode = m["data"]
        self.bus.rosout(2, "/cyborg_visual", f"Dome visual mode set to {m['data']}")

    def _on_spoken(self, text: str) -> None:
        self.bus.rosout(2, "/cyborg_audio", f"Finished speaking: {text}")
        self.bus.publish("tts_feedback", {"data": text})
