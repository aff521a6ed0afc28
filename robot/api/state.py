"""GET /api/robot/state/: the latest value and age of everything the dashboard shows."""

from __future__ import annotations

from asgiref.sync import async_to_sync
from drf_spectacular.utils import extend_schema, inline_serializer
from rest_framework import serializers
from rest_framework.request import Request
from rest_framework.response import Response

from robot.api.base import RobotAPIView
from robot.api.common import error_responses
from robot.commands.selectors import arobot_state

_Value = inline_serializer("TopicValue", {
    "value": serializers.JSONField(help_text="The message as the robot sent it."),
    "age_s": serializers.FloatField(help_text="Seconds since the server received it."),
    "t": serializers.FloatField(help_text="Receive time, epoch seconds."),
})


class RobotStateView(RobotAPIView):

    @extend_schema(
        summary="Robot state",
        description="Link status, the latest value of every dashboard topic with its age, the events "
                    "available from the current state, and the last requested mode against the state reached.",
        responses={200: inline_serializer("RobotState", {
            "connected": serializers.BooleanField(help_text="A command can reach the robot: the robot is "
                                                  "connected and the link answers requests."),
            "command_path": serializers.BooleanField(help_text='False: "command path down", the robot link does '
                                                     "not answer requests (nothing would reach the robot)."),
            "link": serializers.DictField(),
            "values": serializers.DictField(child=_Value),
            "available_events": serializers.DictField(child=serializers.CharField()),
            "mode": serializers.DictField(allow_null=True),
        }), **error_responses(401)},
        tags=["robot"],
    )
    def get(self, request: Request) -> Response:
        return Response(async_to_sync(arobot_state)())
