"""Messages as the robot's own serialization writes them, for clients that subscribe with
``cbor-raw`` (Foxglove, Lichtblick): built with rosbags from the full definitions the robot's rosapi
gives (``topics_and_raw_types``), from the JSON message the link already has, so no second upstream
subscription is needed. ROS 1 serialization for two-part type names, CDR for ROS 2's three-part ones.
"""

from __future__ import annotations

import base64
import logging
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

log = logging.getLogger(__name__)

_NUMPY = {"bool": np.bool_, "int8": np.int8, "uint8": np.uint8, "byte": np.uint8, "char": np.uint8,
          "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "uint32": np.uint32, "int64": np.int64,
          "uint64": np.uint64, "float32": np.float32, "float64": np.float64}
_BYTES = frozenset({"uint8", "byte", "char"})  # base64 text on the rosbridge wire
_MISSING = object()  # a field the JSON message leaves out takes its default (null is NaN, for floats)


class Unknown(LookupError):
    """No definition of this type (rosapi did not give one)."""


def store_name(msg_type: str) -> str:
    """rosbags' name of a type: ``pkg/msg/Type`` (a ROS 1 ``pkg/Type`` gains its ``msg``)."""
    parts = msg_type.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else msg_type


class Serializer:
    """The types learnt from the robot, and their serialization."""

    def __init__(self) -> None:
        self.store = get_typestore(Stores.EMPTY)
        self.topics: dict[str, str] = {}  # topic -> type, as the robot names it
        self.texts: dict[str, str] = {}  # type -> full definition text

    def learn(self, topics: list[str], types: list[str], texts: list[str]) -> None:
        """rosapi's ``topics_and_raw_types`` answer."""
        for topic, msg_type, text in zip(topics, types, texts, strict=False):
            self.topics[topic] = msg_type
            if msg_type in self.texts or not text:
                continue
            try:
                self.store.register(get_types_from_msg(text, store_name(msg_type)))
                self.texts[msg_type] = text
            except Exception as exc:  # a definition rosbags cannot read, or one that changed: say so once
                log.warning("cannot serialize %s for cbor-raw clients: %s", msg_type, exc)

    def knows(self, msg_type: str) -> bool:
        return msg_type in self.texts

    def serialize(self, msg_type: str, msg: dict[str, Any]) -> bytes:
        name = store_name(msg_type)
        if name not in self.store.fielddefs:
            raise Unknown(msg_type)
        message = self._message(name, msg)
        if msg_type.count("/") == 2:
            return bytes(self.store.serialize_cdr(message, name))
        return bytes(self.store.serialize_ros1(message, name))

    def _message(self, name: str, value: Any) -> Any:
        value = value if isinstance(value, dict) else {}
        if name in ("builtin_interfaces/msg/Time", "builtin_interfaces/msg/Duration"):
            return self.store.types[name](sec=int(value.get("secs", value.get("sec", 0)) or 0),
                                          nanosec=int(value.get("nsecs", value.get("nanosec", 0)) or 0))
        _, fields = self.store.fielddefs[name]
        return self.store.types[name](**{field: self._field(desc, value.get(field, _MISSING))
                                         for field, desc in fields})

    def _field(self, desc: tuple[Any, Any], value: Any) -> Any:
        kind, detail = desc
        if kind == Nodetype.BASE:
            return _base(detail[0], value)
        if kind == Nodetype.NAME:
            return self._message(detail, value)
        (item_kind, item_detail), length = detail
        value = None if value is _MISSING else value
        if item_kind == Nodetype.BASE and item_detail[0] != "string":
            base = item_detail[0]
            if base in _BYTES and isinstance(value, str):
                array = np.frombuffer(base64.b64decode(value), dtype=np.uint8)
            else:
                array = np.array([np.nan if v is None else v for v in value or []], dtype=_NUMPY[base])
            if kind == Nodetype.ARRAY and len(array) != length:
                array = np.resize(array, length) if len(array) else np.zeros(length, dtype=_NUMPY[base])
            return array
        items = list(value or [])
        if kind == Nodetype.ARRAY:
            items = (items + [None] * length)[:length]
        return [self._field((item_kind, item_detail), v) for v in items]


def _base(base: str, value: Any) -> Any:
    if value is _MISSING:
        value = "" if base == "string" else 0
    if base == "string":
        return "" if value is None else str(value)
    if base == "bool":
        return bool(value)
    if base.startswith("float"):
        return float("nan") if value is None else float(value)
    return int(value or 0)
