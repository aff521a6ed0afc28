"""Streamed exports of one topic and time range: CSV, JSON Lines, MCAP (opens in Foxglove), WAV (audio).

Each format is a generator of byte chunks over a server-side iterator, so an export of
millions of rows never sits in memory.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Iterator
from datetime import datetime
from itertools import batched
from typing import IO, Any, cast

from history.audio import export_wav
from history.mcapexport import JsonMcap
from history.models import Sample

FORMATS: dict[str, tuple[str, str]] = {
    "csv": ("text/csv; charset=utf-8", "csv"),
    "jsonl": ("application/x-ndjson", "jsonl"),
    "mcap": ("application/octet-stream", "mcap"),
    "wav": ("audio/wav", "wav"),
}
CHUNK_ROWS = 2000


def _rows(topic: str, start: datetime, end: datetime) -> Iterator[tuple[str, datetime, Any]]:
    return (
        Sample.objects.filter(topic=topic, received_at__gte=start, received_at__lt=end)
        .order_by("received_at", "id")
        .values_list("msg_type", "received_at", "data")
        .iterator(chunk_size=CHUNK_ROWS)
    )


def _dumps(value: Any) -> str:
    return json.dumps(value, separators=(",", ":"), ensure_ascii=False)


def scalar_columns(msg: Any, prefix: str = "") -> list[str]:
    """Dotted paths of the scalar leaves outside arrays (the CSV's columns)."""
    paths: list[str] = []
    for key, value in msg.items() if isinstance(msg, dict) else ():
        if isinstance(value, dict):
            paths.extend(scalar_columns(value, f"{prefix}{key}."))
        elif not isinstance(value, list):
            paths.append(f"{prefix}{key}")
    return paths


def pick(msg: Any, path: str) -> Any:
    """The value at a column's path (None where this message lacks it)."""
    for part in path.split("."):
        msg = msg.get(part) if isinstance(msg, dict) else None
    return msg


def export_csv(topic: str, start: datetime, end: datetime) -> Iterator[bytes]:
    """One row per sample: time, type, the first message's scalar fields, then the whole message."""
    sink = _Sink()
    out = csv.writer(sink)
    columns: list[str] | None = None
    for n, (msg_type, received_at, data) in enumerate(_rows(topic, start, end), 1):
        if columns is None:
            columns = scalar_columns(data)
            out.writerow(["received_at", "topic", "msg_type", *columns, "message"])
        out.writerow([received_at.isoformat(), topic, msg_type, *(pick(data, c) for c in columns), _dumps(data)])
        if n % CHUNK_ROWS == 0:
            yield sink.drain()
    if columns is None:
        out.writerow(["received_at", "topic", "msg_type", "message"])
    yield sink.drain()


def export_jsonl(topic: str, start: datetime, end: datetime) -> Iterator[bytes]:
    for batch in batched(_rows(topic, start, end), CHUNK_ROWS):
        yield "".join(_dumps({"topic": topic, "msg_type": msg_type, "received_at": received_at.isoformat(),
                              "msg": data}) + "\n" for msg_type, received_at, data in batch).encode()


class _Sink:
    """A write-only stream the writers fill (text as UTF-8) and the generator empties; tell() keeps
    counting, for the MCAP writer's offsets."""

    def __init__(self) -> None:
        self.chunks: list[bytes] = []
        self.offset = 0

    def write(self, data: bytes | str) -> int:
        chunk = data.encode() if isinstance(data, str) else bytes(data)
        self.chunks.append(chunk)
        self.offset += len(chunk)
        return len(data)

    def tell(self) -> int:
        return self.offset

    def drain(self) -> bytes:
        data, self.chunks = b"".join(self.chunks), []
        return data


def export_mcap(topic: str, start: datetime, end: datetime) -> Iterator[bytes]:
    """MCAP with JSON message encoding: one channel for the topic, one schema per message type."""
    sink = _Sink()
    # The writer only calls write() and tell(), which is all _Sink has of a file.
    mcap = JsonMcap(cast(IO[Any], sink), chunk_size=1024 * 1024)
    for n, (msg_type, received_at, data) in enumerate(_rows(topic, start, end), 1):
        mcap.add(topic, msg_type, received_at.timestamp(), data, sequence=n)
        if n % CHUNK_ROWS == 0:
            yield sink.drain()
    mcap.writer.finish()
    yield sink.drain()


EXPORTERS = {"csv": export_csv, "jsonl": export_jsonl, "mcap": export_mcap, "wav": export_wav}
