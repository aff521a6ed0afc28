"""Recorded audio as a WAV file: the PCM chunks of an AudioData topic, in time order.

Audio is stored only when an admin gives its topic a recording policy (the defaults hold
none, and discovery adds audio topics switched off). The WAV header needs the data's length
up front, so the export reads the range twice: once to count the bytes, once to stream them.
"""

from __future__ import annotations

import base64
import binascii
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from history.models import Sample, TopicPolicy
from robot import interface as ri
from robot.live.state import get_store

AUDIO_DATA_TYPE = "audio_common_msgs/AudioData"
AUDIO_INFO_TYPE = "audio_common_msgs/AudioInfo"
# Each registry audio topic's info topic; other audio topics declare theirs on "<name>_info".
INFO_KEYS = {"audio": "audio_info", "speaker": "speaker_info"}
BYTES_PER_SAMPLE = 2
CHUNK_ROWS = 500


@dataclass(frozen=True)
class WavFormat:
    rate: int = 16000
    channels: int = 1


def is_audio_type(msg_type: str) -> bool:
    return msg_type == AUDIO_DATA_TYPE


def topic_type(topic: str) -> str:
    """The topic's message type as its policy, its samples or the registry know it."""
    known = TopicPolicy.objects.filter(topic=topic).values_list("msg_type", flat=True).first()
    if not known:
        known = Sample.objects.filter(topic=topic).values_list("msg_type", flat=True).first()
    if not known and (registered := ri.topic_by_name(topic)) is not None:
        known = registered.type
    return known or ""


def info_key(topic: str) -> str | None:
    """The registry key of the topic's AudioInfo, for a registry audio topic."""
    return next((info for key, info in INFO_KEYS.items() if ri.topic(key).name == topic), None)


def info_topic(topic: str) -> str:
    key = info_key(topic)
    return ri.topic(key).name if key else f"{topic}_info"


def declared_info(topic: str, before: datetime) -> dict[str, Any] | None:
    """The topic's AudioInfo: the last one recorded before the range ends (it is latched, so an
    earlier one holds), else the latched one the link keeps, else the speaker's own declaration."""
    recorded = (Sample.objects.filter(topic=info_topic(topic), received_at__lt=before)
                .order_by("-received_at", "-id").values_list("data", flat=True).first())
    if isinstance(recorded, dict):
        return recorded
    key = info_key(topic)
    latched = get_store().get_all().get(key) if key else None
    if latched and isinstance(latched.get("msg"), dict):
        return latched["msg"]
    if topic == ri.topic("speaker").name:
        return ri.speaker_info()
    return None


def wav_format(topic: str, end: datetime) -> tuple[WavFormat | None, str | None]:
    """The WAV format of a topic's recording, or why it cannot be exported as WAV."""
    msg_type = topic_type(topic)
    if not is_audio_type(msg_type):
        shown = msg_type or "unknown type"
        return None, f"only {AUDIO_DATA_TYPE} topics export as WAV; {topic} is {shown}"
    info = declared_info(topic, end) or {}
    coding = str(info.get("coding_format") or "wave").lower()
    if coding not in ("wave", "wav", "pcm", "raw"):
        return None, f"{topic} is recorded as {coding}, not raw PCM: export it as jsonl or mcap instead"
    sample_format = str(info.get("sample_format") or "S16LE").upper()
    if sample_format != "S16LE":
        return None, f"{topic} is recorded as {sample_format}; WAV export takes S16LE"
    defaults = WavFormat()
    return WavFormat(rate=int(info.get("sample_rate") or defaults.rate),
                     channels=int(info.get("channels") or defaults.channels)), None


def chunk_bytes(msg: Any) -> bytes:
    """An AudioData's bytes: rosbridge sends uint8[] as base64; a plain list of ints also works."""
    data = msg.get("data") if isinstance(msg, dict) else None
    if isinstance(data, str):
        try:
            return base64.b64decode(data, validate=True)
        except (binascii.Error, ValueError):
            return b""
    if isinstance(data, list) and all(isinstance(b, int) and 0 <= b < 256 for b in data):
        return bytes(data)
    return b""


def _chunks(topic: str, start: datetime, end: datetime, frame: int) -> Iterator[bytes]:
    rows = (Sample.objects.filter(topic=topic, received_at__gte=start, received_at__lt=end)
            .order_by("received_at", "id").values_list("data", flat=True).iterator(chunk_size=CHUNK_ROWS))
    for msg in rows:
        data = chunk_bytes(msg)
        # A torn chunk would shift every later sample; keep whole frames only.
        yield data[:len(data) - len(data) % frame]


def wav_header(fmt: WavFormat, data_bytes: int) -> bytes:
    block = fmt.channels * BYTES_PER_SAMPLE
    return (b"RIFF" + struct.pack("<I", 36 + data_bytes) + b"WAVE"
            + b"fmt " + struct.pack("<IHHIIHH", 16, 1, fmt.channels, fmt.rate, fmt.rate * block, block, 16)
            + b"data" + struct.pack("<I", data_bytes))


def export_wav(topic: str, start: datetime, end: datetime) -> Iterator[bytes]:
    fmt, problem = wav_format(topic, end)
    if fmt is None:
        raise ValueError(problem)
    frame = fmt.channels * BYTES_PER_SAMPLE
    total = sum(len(data) for data in _chunks(topic, start, end, frame))
    yield wav_header(fmt, total)
    # Rows may arrive (or expire) between the two reads: send exactly what the header declares.
    remaining, pending = total, bytearray()
    for data in _chunks(topic, start, end, frame):
        pending += data[:remaining]
        remaining = max(0, remaining - len(data))
        if len(pending) >= 256 * 1024:
            yield bytes(pending)
            pending.clear()
        if not remaining:
            break
    yield bytes(pending) + bytes(remaining)
