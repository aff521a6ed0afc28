"""API input/output shapes for history."""

from __future__ import annotations

import math
import time
from datetime import UTC, datetime, timedelta

from django.conf import settings
from django.utils.dateparse import parse_datetime
from rest_framework import serializers

from history.audio import wav_format
from history.downsample import BadField, parse_field
from history.export import FORMATS
from history.models import Mode
from history.storage import utc

DEFAULT_SPAN = timedelta(hours=1)
MESSAGES_MAX = 1000
# Times the API accepts (epoch seconds): 1970-01-01 up to 2200-01-01 UTC.
TIME_MIN_S, TIME_MAX_S = 0.0, 7258118400.0


def parse_time(value: str, *, name: str) -> datetime:
    """ISO 8601 (naive = UTC) or epoch seconds, between 1970 and 2200."""
    try:
        seconds = float(value)
    except ValueError:
        try:
            parsed = parse_datetime(value.replace(" ", "+"))
        except ValueError as exc:  # well-formed but impossible, e.g. month 13
            raise serializers.ValidationError({name: f"{value!r} is not a valid time: {exc}"}) from None
        if parsed is None:
            raise serializers.ValidationError({name: f"{value!r} is not an ISO 8601 time or epoch seconds"}) from None
        try:
            seconds = (parsed if parsed.tzinfo else parsed.replace(tzinfo=UTC)).timestamp()
        except (OverflowError, ValueError):
            seconds = math.inf
    if not math.isfinite(seconds) or not TIME_MIN_S <= seconds <= TIME_MAX_S:
        raise serializers.ValidationError({name: "must be a time between 1970-01-01 and 2200-01-01 UTC"})
    return utc(seconds)


class TimelineIn(serializers.Serializer):
    start = serializers.CharField(required=False, help_text="ISO 8601 or epoch seconds; default: an hour before end")
    end = serializers.CharField(required=False, help_text="ISO 8601 or epoch seconds; default: now")

    def validate(self, attrs: dict) -> dict:
        end = parse_time(attrs["end"], name="end") if attrs.get("end") else utc(time.time())
        start = parse_time(attrs["start"], name="start") if attrs.get("start") else end - DEFAULT_SPAN
        if start >= end:
            raise serializers.ValidationError({"start": "start must be before end"})
        return {**attrs, "start": start, "end": end}


class RangeIn(TimelineIn):
    topic = serializers.CharField(max_length=255)


class SeriesIn(RangeIn):
    field = serializers.CharField(max_length=255, help_text="Dotted path, e.g. current_pleasure or pose.position.x")
    max_points = serializers.IntegerField(required=False, min_value=2)

    def validate_field(self, value: str) -> str:
        try:
            parse_field(value)
        except BadField as exc:
            raise serializers.ValidationError(str(exc)) from None
        return value

    def validate_max_points(self, value: int) -> int:
        return min(value, settings.HISTORY_MAX_POINTS)


class ExportIn(RangeIn):
    format = serializers.ChoiceField(
        choices=sorted(FORMATS), default="csv",
        help_text="wav: AudioData topics only (raw S16LE PCM), in the format of their recorded AudioInfo")

    def validate(self, attrs: dict) -> dict:
        attrs = super().validate(attrs)
        if attrs["format"] == "wav":
            _, problem = wav_format(attrs["topic"], attrs["end"])
            if problem:
                raise serializers.ValidationError({"format": problem})
        return attrs


class SeriesOut(serializers.Serializer):
    topic = serializers.CharField()
    field = serializers.CharField()
    bucket_s = serializers.FloatField(help_text="Bucket width; each point is one bucket's min, max, mean, count")
    t = serializers.ListField(child=serializers.FloatField(), help_text="Epoch seconds of each bucket's first sample")
    min = serializers.ListField(child=serializers.FloatField())
    max = serializers.ListField(child=serializers.FloatField())
    mean = serializers.ListField(child=serializers.FloatField())
    count = serializers.ListField(child=serializers.IntegerField())


# Physical ranges of a policy: sampling at most once a day, kept at most ten years.
INTERVAL_MAX_S = 86_400.0
RETENTION_MAX_S = 10 * 365 * 86_400.0
MESSAGE_BYTES_MAX = 64 * 1024 * 1024


class PolicyIn(serializers.Serializer):
    topic = serializers.CharField(max_length=255)
    msg_type = serializers.CharField(max_length=255, required=False, allow_blank=True)
    mode = serializers.ChoiceField(choices=Mode.choices, required=False)
    interval_s = serializers.FloatField(required=False, allow_null=True, min_value=0.05, max_value=INTERVAL_MAX_S)
    retention_s = serializers.FloatField(required=False, allow_null=True, min_value=1, max_value=RETENTION_MAX_S)
    max_message_bytes = serializers.IntegerField(required=False, allow_null=True, min_value=1,
                                                 max_value=MESSAGE_BYTES_MAX)


class PoliciesPatch(serializers.Serializer):
    default_interval_s = serializers.FloatField(required=False, min_value=0.05, max_value=INTERVAL_MAX_S)
    topics = PolicyIn(many=True, required=False)


class PolicyOut(serializers.Serializer):
    topic = serializers.CharField()
    msg_type = serializers.CharField()
    mode = serializers.CharField()
    interval_s = serializers.FloatField(allow_null=True, help_text="The topic's own interval (null = default)")
    effective_interval_s = serializers.FloatField()
    retention_s = serializers.FloatField(allow_null=True)
    max_message_bytes = serializers.IntegerField()


class PoliciesOut(serializers.Serializer):
    default_interval_s = serializers.FloatField()
    topics = PolicyOut(many=True)


class DiscoverIn(serializers.Serializer):
    mode = serializers.ChoiceField(choices=Mode.choices, default=Mode.OFF)


class DiscoverOut(serializers.Serializer):
    discovered = serializers.IntegerField(help_text="Topics the robot reported")
    added = serializers.IntegerField(help_text="Policies added for topics not known before")


class RecordedTopicOut(serializers.Serializer):
    topic = serializers.CharField()
    msg_type = serializers.CharField()
    mode = serializers.ChoiceField(choices=Mode.choices)
    last = serializers.DateTimeField(allow_null=True, help_text="When the newest sample arrived")
    # The metaclass takes declared fields off the class, so these names do not hide Serializer.fields/.data.
    fields = serializers.ListField(  # type: ignore[assignment]
        child=serializers.CharField(), help_text="Plottable numeric fields")
    text = serializers.BooleanField(help_text="Has text fields: read as a table of messages")


class RecordedOut(serializers.Serializer):
    topics = RecordedTopicOut(many=True)


class SpanOut(serializers.Serializer):
    start = serializers.FloatField(help_text="epoch seconds")
    end = serializers.FloatField(help_text="epoch seconds")


class TimelineSegmentOut(SpanOut):
    state = serializers.CharField()


class TimelineOut(SpanOut):
    segments = TimelineSegmentOut(many=True)
    totals = serializers.DictField(child=serializers.FloatField(), help_text="Seconds spent per state")
    counts = serializers.DictField(child=serializers.IntegerField(), help_text="Times each state was entered")
    spans = SpanOut(many=True, help_text="When anything was recorded at all; only these count")


class MessagesIn(RangeIn):
    limit = serializers.IntegerField(required=False, min_value=1, max_value=MESSAGES_MAX, default=MESSAGES_MAX)


class MessageOut(serializers.Serializer):
    t = serializers.FloatField(help_text="epoch seconds (UTC) when it was received")
    data = serializers.DictField(help_text="The message as recorded")  # type: ignore[assignment]


class MessagesOut(serializers.Serializer):
    topic = serializers.CharField()
    messages = MessageOut(many=True, help_text="Newest first")
    truncated = serializers.BooleanField(help_text="More messages in the range than limit")

