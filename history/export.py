"""Streamed exports of one topic and time range: CSV, JSON Lines, MCAP (opens in Foxglove), WAV (audio).

Each format is a generator of byte chunks over a server-side iterator, so an export of
millions of rows never sits in memory.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Iterator
from datetime import datetime
from typing import IO, Any, cast

from history.audio import export_wav
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
    if not isinstance(msg, dict):
        return [prefix] if prefix else []
    paths: list[str] = []
    for key, value in msg.items():
        path = f"{prefix}.{key}" if prefix else key
        if isinstance(value, dict):
            paths.extend(scalar_columns(value, path))
        elif not isinstance(value, list):
            paths.append(path)
    return paths


def pick(msg: Any, path: str) -> Any:
    for part in path.split("."):
        if isinstance(msg, dict):
            msg = msg.get(part)
        elif isinstance(msg, list) and part.isdigit() and int(part) < len(msg):
            msg = msg[int(part)]
        else:
            return None
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
    sink = _Sink()
    for n, (msg_type, received_at, data) in enumerate(_rows(topic, start, end), 1):
        record = {"topic": topic, "msg_type": msg_type, "received_at": received_at.isoformat(), "msg": data}
        sink.write(_dumps(record) + "\n")
        if n % CHUNK_ROWS == 0:
            yield sink.drain()
    yield sink.drain()


def json_schema(msg: Any) -> dict[str, Any]:
    """A JSON Schema inferred from one message (Foxglove uses it to list the fields)."""
    if isinstance(msg, bool):
        return {"type": "boolean"}
    if isinstance(msg, int | float):
        return {"type": "number"}
    if isinstance(msg, str):
        return {"type": "string"}
    if isinstance(msg, list):
        return {"type": "array", "items": json_schema(msg[0]) if msg else {}}
    if isinstance(msg, dict):
        return {"type": "object", "properties": {k: json_schema(v) for k, v in msg.items()}}
    return {}


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

    def flush(self) -> None:
        pass

    def drain(self) -> bytes:
        data, self.chunks = b"".join(self.chunks), []
        return data


def export_mcap(topic: str, start: datetime, end: datetime) -> Iterator[bytes]:
    """MCAP with JSON message encoding: one channel for the topic, one schema per message type."""
    from mcap.writer import CompressionType, Writer

    sink = _Sink()
    # The writer only calls write() and tell(), which is all _Sink has of a file.
    writer = Writer(cast(IO[Any], sink), chunk_size=1024 * 1024, compression=CompressionType.ZSTD)
    writer.start(profile="", library="cyborg-commander")
    channels: dict[str, int] = {}
    for n, (msg_type, received_at, data) in enumerate(_rows(topic, start, end), 1):
        channel = channels.get(msg_type)
        if channel is None:
            schema = writer.register_schema(
                name=msg_type, encoding="jsonschema", data=_dumps(json_schema(data)).encode()
            )
            channel = channels[msg_type] = writer.register_channel(
                topic=topic, message_encoding="json", schema_id=schema, metadata={"ros_type": msg_type}
            )
        stamp = int(received_at.timestamp() * 1e9)
        writer.add_message(channel_id=channel, log_time=stamp, publish_time=stamp, data=_dumps(data).encode(),
                           sequence=n)
        if n % CHUNK_ROWS == 0:
            yield sink.drain()
    writer.finish()
    yield sink.drain()


EXPORTERS = {"csv": export_csv, "jsonl": export_jsonl, "mcap": export_mcap, "wav": export_wav}
