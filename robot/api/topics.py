"""GET /api/topics/: every topic the robot has; GET /api/topics/rate/: one topic's measured rate."""

from __future__ import annotations

from typing import Any

from asgiref.sync import async_to_sync
from drf_spectacular.utils import extend_schema, inline_serializer
from rest_framework import serializers
from rest_framework.request import Request
from rest_framework.response import Response

from robot import interface as ri
from robot.api.base import robot_api_view
from robot.api.common import error_responses, same, shape
from robot.link.bus import arequest
from robot.link.watching import RATE_WINDOW_S

LIST_TIMEOUT_S = 8.0


class TopicsIn(serializers.Serializer):
    q = serializers.CharField(required=False, allow_blank=True, max_length=200,
                              help_text="Only topics whose name or type contains this (any case).")


class RateIn(serializers.Serializer):
    topic = serializers.CharField(max_length=ri.TOPIC_NAME_MAX)
    window_s = serializers.FloatField(required=False, default=2.0, min_value=RATE_WINDOW_S[0],
                                      max_value=RATE_WINDOW_S[1], help_text="How long to count messages.")

    def validate_topic(self, value: str) -> str:
        problem = ri.topic_name_problem(value)
        if problem:
            raise serializers.ValidationError(problem)
        return value


TopicOut = shape(
    "TopicOut", **same(serializers.CharField, "name", "type"),
    publishers=serializers.ListField(child=serializers.CharField(), allow_null=True,
                                     help_text="Nodes publishing it (null: the robot's rosapi cannot say)."),
    subscribed=serializers.BooleanField(help_text="The server holds a subscription to it now."))




def topic_list(query: str = "") -> list[dict[str, Any]]:
    reply = async_to_sync(arequest)("topics_list", timeout=LIST_TIMEOUT_S)
    topics = sorted(reply.get("values") or [], key=lambda t: t["name"])
    needle = query.strip().lower()
    return [t for t in topics if needle in t["name"].lower() or needle in t["type"].lower()] if needle else topics


@extend_schema(parameters=[TopicsIn], summary="The robot's topics (rosapi): name, type, publishers",
               responses={200: inline_serializer("RobotTopics", {"topics": TopicOut(many=True)}),
                          **error_responses(401, 503, 504)}, tags=["topics"])
@robot_api_view(["GET"])
def topics_view(request: Request) -> Response:
    q = TopicsIn(data=request.query_params)
    q.is_valid(raise_exception=True)
    return Response({"topics": topic_list(q.validated_data.get("q", ""))})


@extend_schema(parameters=[RateIn], summary="Measure one topic's message rate over a short window",
               responses={200: inline_serializer("TopicRate", {
                   "topic": serializers.CharField(), "type": serializers.CharField(),
                   "hz": serializers.FloatField(), "messages": serializers.IntegerField(),
                   "window_s": serializers.FloatField()}), **error_responses(400, 401, 502, 503, 504)},
               tags=["topics"])
@robot_api_view(["GET"])
def rate_view(request: Request) -> Response:
    q = RateIn(data=request.query_params)
    q.is_valid(raise_exception=True)
    v = q.validated_data
    reply = async_to_sync(arequest)("topics_rate", topic=v["topic"], window_s=v["window_s"],
                                    timeout=v["window_s"] + 5)
    return Response(reply["values"])
