"""An incident as one MCAP file that opens in Foxglove: JSON-encoded channels.

Every recorded topic in the window keeps its ROS name (schema named by its ROS type); the
camera is ``/camera`` as ``foxglove.CompressedImage`` and the pose also ``/pose`` as
``foxglove.PoseInFrame`` (Foxglove's well-known schemas, in their JSON form: bytes as
base64), so the Image and 3D panels show them without any conversion.
"""

from __future__ import annotations

import base64
import io
import json
from typing import Any

from mcap.writer import CompressionType, Writer

from history.export import json_schema
from history.frames import frame_file
from history.models import CameraFrame, Incident, Sample
from history.storage import utc
from robot import interface as ri

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


def _ns(t: float) -> int:
    return round(t * 1e9)


def _stamp(t: float) -> dict[str, int]:
    ns = _ns(t)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _json(value: Any) -> bytes:
    return json.dumps(value, separators=(",", ":")).encode()


def topics_in(start: float, end: float) -> list[str]:
    return list(Sample.objects.filter(received_at__gte=utc(start), received_at__lte=utc(end))
                .values_list("topic", flat=True).distinct())


def incident_mcap(incident: Incident, *, hidden: frozenset[str] = frozenset()) -> bytes:
    """The incident's window: every recorded message and camera frame in it."""
    out = io.BytesIO()
    writer = Writer(out, compression=CompressionType.ZSTD)
    writer.start(profile="", library="cyborg-commander")
    writer.add_metadata("incident", {"id": str(incident.pk), "kind": incident.kind, "t": f"{incident.t:.3f}",
                                     "summary": incident.summary, "by": incident.by, "driver": incident.driver})
    channels: dict[str, int] = {}
    pose_name = ri.topic("robot_pose").name

    def add(topic: str, schema_name: str, schema: dict[str, Any], t: float, message: Any) -> None:
        if topic not in channels:
            schema_id = writer.register_schema(name=schema_name, encoding="jsonschema", data=_json(schema))
            channels[topic] = writer.register_channel(topic=topic, message_encoding="json", schema_id=schema_id,
                                                      metadata={"ros_type": schema_name})
        writer.add_message(channels[topic], log_time=_ns(t), publish_time=_ns(t), data=_json(message))

    rows = (Sample.objects.filter(received_at__gte=utc(incident.start), received_at__lte=utc(incident.end))
            .exclude(topic__in=hidden).order_by("received_at")
            .values_list("topic", "msg_type", "received_at", "data"))
    for topic, msg_type, at, data in rows.iterator(chunk_size=2000):
        t = at.timestamp()
        add(topic, msg_type, json_schema(data), t, data)
        if topic == pose_name and isinstance(data, dict):
            pose = {"timestamp": _stamp(t), "frame_id": ri.MAP_FRAME, "pose": data}
            add(POSE_TOPIC, "foxglove.PoseInFrame", POSE_IN_FRAME_SCHEMA, t, pose)
    frames = CameraFrame.objects.filter(t__gte=incident.start, t__lte=incident.end).order_by("t")
    for frame in frames.iterator(chunk_size=500):
        try:
            jpeg = frame_file(frame).read_bytes()
        except OSError:
            continue  # its file is gone (a disk cleaned by hand): the rest still exports
        image = {"timestamp": _stamp(frame.t), "frame_id": "camera", "format": "jpeg",
                 "data": base64.b64encode(jpeg).decode()}
        add(CAMERA_TOPIC, "foxglove.CompressedImage", COMPRESSED_IMAGE_SCHEMA, frame.t, image)
    writer.finish()
    return out.getvalue()
