"""Checks on operator audio before it may reach the robot's speakers.

The browser sends raw PCM in the speaker's own format (``robot.interface``: S16LE, 16 kHz,
mono), so the server checks and forwards bytes without converting them. 16-bit integer
samples cannot be NaN or infinite: "finite samples" is guaranteed by the format, which is
why a talk that declares any other format (float samples among them) is refused outright.
"""

from __future__ import annotations

import time
from typing import Any

from robot import interface as ri

BYTES_PER_SAMPLE = 2
# How far ahead of real time a talker may get (network bunching) before chunks are refused.
RATE_ALLOWANCE_S = 0.3


def chunk_bounds() -> tuple[int, int]:
    """Smallest and largest chunk in bytes (the robot's player wants 20-100 ms chunks)."""
    low, high = ri.SPEAKER_CHUNK_MS
    per_ms = ri.SPEAKER_RATE_HZ * ri.SPEAKER_CHANNELS * BYTES_PER_SAMPLE // 1000
    return low * per_ms, high * per_ms


def format_problem(declared: dict[str, Any]) -> str | None:
    """Why a talk's declared format cannot go to the speakers, or None."""
    wanted = {"format": ri.SPEAKER_SAMPLE_FORMAT, "rate": ri.SPEAKER_RATE_HZ, "channels": ri.SPEAKER_CHANNELS}
    for name, value in wanted.items():
        if declared.get(name) != value:
            wants = f"{ri.SPEAKER_SAMPLE_FORMAT} {ri.SPEAKER_RATE_HZ} Hz mono"
            return f"audio must be {wants}; got {name}={declared.get(name)!r}"
    return None


def chunk_problem(data: bytes) -> str | None:
    low, high = chunk_bounds()
    if len(data) % (BYTES_PER_SAMPLE * ri.SPEAKER_CHANNELS):
        return f"a {len(data)}-byte chunk is not whole {ri.SPEAKER_SAMPLE_FORMAT} samples"
    if not low <= len(data) <= high:
        span = f"{ri.SPEAKER_CHUNK_MS[0]}-{ri.SPEAKER_CHUNK_MS[1]} ms ({low}-{high} bytes)"
        return f"a chunk must hold {span}; got {len(data)}"
    return None


def duration_s(data: bytes) -> float:
    return len(data) / (BYTES_PER_SAMPLE * ri.SPEAKER_CHANNELS * ri.SPEAKER_RATE_HZ)


class Pacer:
    """Refuses audio arriving faster than it plays: a talker may be at most RATE_ALLOWANCE_S ahead."""

    def __init__(self, allowance_s: float = RATE_ALLOWANCE_S) -> None:
        self.started = time.monotonic()
        self.audio_s = 0.0
        self.allowance_s = allowance_s

    def admit(self, data: bytes) -> str | None:
        elapsed = time.monotonic() - self.started
        seconds = duration_s(data)
        if self.audio_s + seconds > elapsed + self.allowance_s:
            return f"audio arrives faster than real time ({self.audio_s + seconds:.2f} s in {elapsed:.2f} s)"
        self.audio_s += seconds
        return None
