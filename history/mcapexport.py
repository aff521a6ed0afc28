"""MCAP files that open in Foxglove (JSON-encoded channels): a topic's export and an incident.

In an incident every recorded topic in the window keeps its ROS name (schema named by its ROS type); the
camera is ``/camera`` as ``foxglove.CompressedImage`` and the pose also ``/pose`` as
``foxglove.PoseInFrame`` (Foxglove's well-known schemas, in their JSON form: bytes as
base64), so the Image and 3D panels show them without any conversion.
"""

from __future__ import annotations

import base64
import io
import json
from typing import IO, Any

from mcap.writer import CompressionType, Writer

from history.frames import frame_file
from history.models import CameraFrame, Incident, Sample
from history.storage import utc
from robot import interface as ri
from robot.link.dialect import to_robot

CAMERA_TOPIC = "/camera"
POSE_TOPIC = "/pose"
_STAMPED = {
    "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
    "frame_id": {"type": "string"},
}
COMPRESSED_IMAGE_SCHEMA = {
    "type": "object", "title": "foxglove.CompressedImage",
    "properties": {
        **_STAMPED,
        "data": {"type": "string", "contentEncoding": "base64"},
        "format": {"type": "string"},
    },
}
POSE_IN_FRAME_SCHEMA = {
    "type": "object", "title": "foxglove.PoseInFrame",
    "properties": {
        **_STAMPED,
        "pose": {"type": "object", "properties": {
            "position": {"type": "object", "properties": {a: {"type": "number"} for a in "xyz"}},
            "orientation": {"type": "object", "properties": {a: {"type": "number"} for a in "xyzw"}},
        }},
    },
}


def _stamp(t: float) -> dict[str, int]:
    sec, nsec = divmod(round(t * 1e9), 1_000_000_000)
    return {"sec": sec, "nsec": nsec}


def _json(value: Any) -> bytes:
    return json.dumps(value, separators=(",", ":"), ensure_ascii=False).encode()


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


class JsonMcap:
    """An MCAP writer of JSON messages: a channel per topic and schema, registered with its first message."""

    def __init__(self, out: IO[Any], **options: Any) -> None:
        self.writer = Writer(out, compression=CompressionType.ZSTD, **options)
        self.writer.start(profile="", library="cyborg-commander")
        self.channels: dict[tuple[str, str], int] = {}

    def add(self, topic: str, schema_name: str, t: float, message: Any, *, schema: dict[str, Any] | None = None,
            sequence: int = 0) -> None:
        """``message`` at ``t`` (epoch seconds); without a ``schema``, a recorded message as the robot sent
        it (``schema_name`` its type) and its schema inferred from the first one."""
        if schema is None:
            message = to_robot(schema_name, message)
        channel = self.channels.get((topic, schema_name))
        if channel is None:
            schema_id = self.writer.register_schema(name=schema_name, encoding="jsonschema",
                                                    data=_json(schema or json_schema(message)))
            channel = self.channels[topic, schema_name] = self.writer.register_channel(
                topic=topic, message_encoding="json", schema_id=schema_id, metadata={"ros_type": schema_name})
        ns = round(t * 1e9)
        self.writer.add_message(channel, log_time=ns, publish_time=ns, data=_json(message), sequence=sequence)


def topics_in(start: float, end: float) -> list[str]:
    return list(Sample.objects.filter(received_at__gte=utc(start), received_at__lte=utc(end))
                .values_list("topic", flat=True).distinct())


def incident_mcap(incident: Incident, *, hidden: frozenset[str] = frozenset()) -> bytes:
    """The incident's window: every recorded message and camera frame in it."""
    out = io.BytesIO()
    mcap = JsonMcap(out)
    mcap.writer.add_metadata("incident", {"id": str(incident.pk), "kind": incident.kind, "t": f"{incident.t:.3f}",
                                          "summary": incident.summary, "by": incident.by, "driver": incident.driver})
    pose_name = ri.topic("robot_pose").name
    rows = (Sample.objects.filter(received_at__gte=utc(incident.start), received_at__lte=utc(incident.end))
            .exclude(topic__in=hidden).order_by("received_at")
            .values_list("topic", "msg_type", "received_at", "data"))
    for topic, msg_type, at, data in rows.iterator(chunk_size=2000):
        t = at.timestamp()
        mcap.add(topic, msg_type, t, data)
        if topic == pose_name and isinstance(data, dict):
            pose = {"timestamp": _stamp(t), "frame_id": ri.MAP_FRAME, "pose": data}
            mcap.add(POSE_TOPIC, "foxglove.PoseInFrame", t, pose, schema=POSE_IN_FRAME_SCHEMA)
    frames = CameraFrame.objects.filter(t__gte=incident.start, t__lte=incident.end).order_by("t")
    for frame in frames.iterator(chunk_size=500):
        try:
            jpeg = frame_file(frame).read_bytes()
        except OSError:
            continue  # its file is gone (a disk cleaned by hand): the rest still exports
        image = {"timestamp": _stamp(frame.t), "frame_id": "camera", "format": "jpeg",
                 "data": base64.b64encode(jpeg).decode()}
        mcap.add(CAMERA_TOPIC, "foxglove.CompressedImage", frame.t, image, schema=COMPRESSED_IMAGE_SCHEMA)
    mcap.writer.finish()
    return out.getvalue()
