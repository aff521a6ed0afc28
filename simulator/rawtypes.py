"""What a ROS 1 rosbridge serves Foxglove and Lichtblick: full message definitions
(``/rosapi/topics_and_raw_types``, gendeps' ``--cat`` layout) and ``cbor-raw`` subscriptions, whose
``publish`` frames are CBOR with the message's ROS 1 serialized bytes. The serializer is written out
here from the simulator's own schemas (not borrowed from the product), so the two can check each other.
"""

from __future__ import annotations

import base64
import struct
import time
from typing import Any

import cbor2

from . import messages

SEPARATOR = "=" * 80
_FORMATS = {"bool": "?", "int8": "b", "byte": "b", "uint8": "B", "char": "B", "int16": "h", "uint16": "H",
            "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q", "float32": "f", "float64": "d"}


def _definition(msg_type: str) -> str:
    return "\n".join(f"{ftype}{'' if length is None else '[]' if length < 0 else f'[{length}]'} {name}"
                     for name, ftype, length in messages.SCHEMAS[msg_type])


def _dependencies(msg_type: str) -> list[str]:
    found: list[str] = []
    todo = [msg_type]
    while todo:
        for _, ftype, _ in messages.SCHEMAS[todo.pop(0)]:
            if ftype not in messages.PRIMITIVES and ftype not in found and messages.known(ftype):
                found.append(ftype)
                todo.append(ftype)
    return found


def full_text(msg_type: str) -> str:
    """The definition with every type it uses after it, as ROS 1's rosapi gives it (empty if unknown)."""
    if not messages.known(msg_type):
        return ""
    parts = [_definition(msg_type)]
    parts += [f"{SEPARATOR}\nMSG: {dep}\n{_definition(dep)}" for dep in _dependencies(msg_type)]
    return "\n".join(parts) + "\n"


def serialize(msg_type: str, msg: dict[str, Any]) -> bytes:
    """``msg`` (rosbridge JSON) in ROS 1's serialization: little-endian, strings and variable arrays
    prefixed by a uint32 length, time and duration as two 32-bit words."""
    out = bytearray()
    _message(out, msg_type, msg)
    return bytes(out)


def _message(out: bytearray, msg_type: str, msg: dict[str, Any]) -> None:
    for name, ftype, length in messages.SCHEMAS[msg_type]:
        value = msg.get(name)
        if length is None:
            _value(out, ftype, value)
            continue
        if ftype in ("uint8", "char") and isinstance(value, str):
            data = base64.b64decode(value)
            if length < 0:
                out += struct.pack("<I", len(data))
            out += data
            continue
        items = list(value or [])
        if length < 0:
            out += struct.pack("<I", len(items))
        for item in items:
            _value(out, ftype, item)


def _value(out: bytearray, ftype: str, value: Any) -> None:
    if ftype == "string":
        data = str(value or "").encode()
        out += struct.pack("<I", len(data)) + data
    elif ftype in ("time", "duration"):
        value = value or {}
        out += struct.pack("<Ii" if ftype == "duration" else "<II", int(value.get("secs", 0)),
                           int(value.get("nsecs", 0)))
    elif ftype in _FORMATS:
        if value is None:
            value = float("nan") if ftype.startswith("float") else 0
        out += struct.pack("<" + _FORMATS[ftype], value)
    else:
        _message(out, ftype, value or {})


def cbor_raw_frame(topic: str, msg_type: str, msg: dict[str, Any]) -> bytes:
    """rosbridge's ``cbor-raw`` publish frame: receive time and the serialized message."""
    now = time.time()
    secs = int(now)
    return cbor2.dumps({"op": "publish", "topic": topic,
                        "msg": {"secs": secs, "nsecs": int((now - secs) * 1e9), "bytes": serialize(msg_type, msg)}})
