"""History API: recording policies, downsampled series, streamed exports, state timeline."""

from __future__ import annotations

from collections.abc import AsyncIterator, Iterable, Iterator
from typing import Any

from asgiref.sync import sync_to_async
from django.conf import settings
from django.db import transaction
from django.http import StreamingHttpResponse
from drf_spectacular.utils import extend_schema
from rest_framework import exceptions, permissions
from rest_framework.decorators import api_view, permission_classes
from rest_framework.negotiation import BaseContentNegotiation
from rest_framework.parsers import BaseParser
from rest_framework.renderers import BaseRenderer
from rest_framework.request import Request
from rest_framework.response import Response
from rest_framework.views import APIView

from cyborg_site.roles import is_admin
from history import serializers as s
from history.access import refusal, refused_topics
from history.downsample import series
from history.export import EXPORTERS, FORMATS
from history.models import RecordingSettings, TopicPolicy
from history.policies import default_interval_set, effective_interval, policies_discover, policy_upsert
from history.policy_audit import default_interval_audited, policies_audited
from history.selectors import recorded_messages, recorded_topics, state_timeline


class AdminWrites(permissions.BasePermission):
    message = "Only admins may change recording policies."

    def has_permission(self, request: Request, view: Any) -> bool:
        return request.method in permissions.SAFE_METHODS or is_admin(request.user)


def _topic_query(request: Request, shape: type[s.RangeIn]) -> dict[str, Any]:
    """The request's query, validated; a topic for operators only is refused to a viewer."""
    q = shape(data=request.query_params)
    q.is_valid(raise_exception=True)
    if refused_topics(request.user, [q.validated_data["topic"]]):
        raise exceptions.PermissionDenied(refusal(q.validated_data["topic"]))
    return q.validated_data


def _policies() -> dict[str, Any]:
    default_s = RecordingSettings.load().effective_interval_s
    return {
        "default_interval_s": default_s,
        "topics": [
            {"topic": p.topic, "msg_type": p.msg_type, "mode": p.mode, "interval_s": p.interval_s,
             "effective_interval_s": effective_interval(p.interval_s, default_s), "retention_s": p.retention_s,
             "max_message_bytes": p.max_message_bytes or settings.HISTORY_MAX_MESSAGE_BYTES}
            for p in TopicPolicy.objects.all()
        ],
    }


@extend_schema(methods=["GET"], responses={200: s.PoliciesOut}, summary="Recording policies")
@extend_schema(methods=["PATCH"], request=s.PoliciesPatch, responses={200: s.PoliciesOut},
               summary="Change the default interval and/or topics' policies (admins; takes effect within ~1 s)")
@api_view(["GET", "PATCH"])
@permission_classes([permissions.IsAuthenticated, AdminWrites])
def topics_view(request: Request) -> Response:
    if request.method == "PATCH":
        body = s.PoliciesPatch(data=request.data)
        body.is_valid(raise_exception=True)
        items = body.validated_data.get("topics", [])
        with (transaction.atomic(), default_interval_audited(user=request.user, source="api"),
              policies_audited(user=request.user, source="api", topics=[item["topic"] for item in items])):
            if "default_interval_s" in body.validated_data:
                default_interval_set(seconds=body.validated_data["default_interval_s"])
            for item in items:
                policy_upsert(**item)
    return Response(_policies())


@extend_schema(request=s.DiscoverIn, responses={200: s.DiscoverOut},
               summary="Add a policy for every topic the robot reports (/rosapi/topics)")
@api_view(["POST"])
@permission_classes([permissions.IsAuthenticated, AdminWrites])
def discover_view(request: Request) -> Response:
    body = s.DiscoverIn(data=request.data)
    body.is_valid(raise_exception=True)
    discovered, added = policies_discover(user=request.user, source="api", mode=body.validated_data["mode"])
    return Response({"discovered": discovered, "added": added})


@extend_schema(parameters=[s.SeriesIn], responses={200: s.SeriesOut},
               summary="A numeric field over time, downsampled to at most max_points min/max buckets")
@api_view(["GET"])
def samples_view(request: Request) -> Response:
    v = _topic_query(request, s.SeriesIn)
    result = series(topic=v["topic"], field=v["field"], start=v["start"], end=v["end"],
                    max_points=v.get("max_points") or settings.HISTORY_MAX_POINTS)
    return Response(vars(result))


class _IgnoreFormatParameter(BaseContentNegotiation):
    """``format`` here names the export format, not a DRF renderer (which would answer 404)."""

    def select_renderer(self, request: Request, renderers: Iterable[BaseRenderer],
                        format_suffix: str | None = None) -> tuple[BaseRenderer, str]:
        first = next(iter(renderers))
        return first, first.media_type

    def select_parser(self, request: Request, parsers: Iterable[BaseParser]) -> BaseParser | None:
        return next(iter(parsers), None)


class ExportView(APIView):
    content_negotiation_class = _IgnoreFormatParameter

    @extend_schema(parameters=[s.ExportIn],
                   responses={(200, content_type): bytes for content_type, _ in FORMATS.values()},
                   summary="Stream a topic's samples as CSV, JSON Lines, MCAP (JSON encoding, opens in Foxglove) "
                           "or, for a recorded audio topic, WAV")
    def get(self, request: Request) -> StreamingHttpResponse:
        v = _topic_query(request, s.ExportIn)
        content_type, ext = FORMATS[v["format"]]
        chunks = EXPORTERS[v["format"]](v["topic"], v["start"], v["end"])
        response = StreamingHttpResponse(_async_chunks(chunks), content_type=content_type)
        name = v["topic"].strip("/").replace("/", "_") or "topic"
        response["Content-Disposition"] = f'attachment; filename="{name}-{v["start"]:%Y%m%dT%H%M%S}.{ext}"'
        return response


async def _async_chunks(chunks: Iterator[bytes]) -> AsyncIterator[bytes]:
    # Under ASGI a sync iterator would be read into memory whole; pull it chunk by chunk instead.
    step = sync_to_async(next, thread_sensitive=True)
    done = object()
    # next(iterator, default): the stubs type sync_to_async(next) with next's one-argument form.
    while (chunk := await step(chunks, done)) is not done:  # type: ignore[call-arg]
        yield chunk


@extend_schema(responses={200: s.RecordedOut}, summary="Recorded topics with their plottable fields")
@api_view(["GET"])
def recorded_view(request: Request) -> Response:
    return Response({"topics": recorded_topics()})


@extend_schema(parameters=[s.MessagesIn], responses={200: s.MessagesOut},
               summary="A topic's recorded messages in a range, newest first (text topics: speech, log, state changes)")
@api_view(["GET"])
def messages_view(request: Request) -> Response:
    v = _topic_query(request, s.MessagesIn)
    rows, truncated = recorded_messages(topic=v["topic"], start=v["start"], end=v["end"], limit=v["limit"])
    return Response({"topic": v["topic"], "messages": rows, "truncated": truncated})


@extend_schema(parameters=[s.TimelineIn], responses={200: s.TimelineOut},
               summary="Time spent per state-machine state, from recorded state changes")
@api_view(["GET"])
def timeline_view(request: Request) -> Response:
    q = s.TimelineIn(data=request.query_params)
    q.is_valid(raise_exception=True)
    t = state_timeline(start=q.validated_data["start"], end=q.validated_data["end"])
    return Response({**vars(t), "spans": [{"start": lo, "end": hi} for lo, hi in t.spans]})
