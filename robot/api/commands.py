"""POST endpoints that command the robot; one view per command, all thin.

Validation lives in the command functions (one path for page, API and websocket, audited
either way); the serializers here describe the input for the OpenAPI schema.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, ClassVar

from drf_spectacular.utils import extend_schema, inline_serializer
from rest_framework import serializers
from rest_framework.request import Request
from rest_framework.response import Response
from rest_framework.views import APIView

from robot.api.base import CommandAPIView, run
from robot.api.common import error_responses
from robot.api.validation import body_object, reject_unknown
from robot.commands import modes, motors, tool
from robot.commands.pipeline import Command
from robot.commands.validation import EVENT_MAX, MODE_NAMES, SPEECH_MAX

CommandOut = inline_serializer("CommandResult", {
    "ok": serializers.BooleanField(),
    "action": serializers.CharField(),
    "outcome": serializers.CharField(help_text="What was done, for a person."),
})


def _value_only(build: Callable[[Any], Command]) -> Callable[[Any, Any], Command]:
    return lambda value, user: build(value)


class FieldCommandView(CommandAPIView):
    action_name: ClassVar[str]
    field: ClassVar[str]
    command: ClassVar[Callable[[Any, Any], Command]]  # (value, user) -> the command

    def post(self, request: Request) -> Response:
        data = body_object(request)
        reject_unknown(data, [self.field])
        outcome = run(request, type(self).command(data.get(self.field), request.user))
        return Response({"ok": True, "action": self.action_name, "outcome": outcome})


def _command_view(name: str, *, action: str, field: str, command: Callable[[Any, Any], Command], summary: str,
                  description: str, input_field: serializers.Field, errors: tuple[int, ...] = ()) -> type[APIView]:
    """One view per command: the class, and its OpenAPI description."""
    view = type(name, (FieldCommandView,), {"action_name": action, "field": field, "command": staticmethod(command),
                                        "__doc__": description})
    return extend_schema(
        summary=summary, description=description, tags=["commands"],
        request=inline_serializer(f"{name.removesuffix('View')}In", {field: input_field}),
        responses={200: CommandOut, **error_responses(400, 401, 403, 409, 429, 503, 504, *errors)},
    )(view)


ModeView = _command_view(
    "ModeView", action="mode", field="mode", summary="Change mode",
    command=lambda mode, user: modes.change_mode(mode, user=user),
    description="Behaviour, Demo, Manual or Stop. With `MODE_COMMANDER=server` the server runs the commander's "
                "sequence itself; with `robot` it publishes the mode on `robot_mode`. One change at a time (409).",
    input_field=serializers.ChoiceField(choices=MODE_NAMES))
EventView = _command_view(
    "EventView", action="event", field="event", command=_value_only(tool.send_event), summary="Send event",
    description="Register a state machine event (see `available_events` in the robot state).",
    input_field=serializers.RegexField(r"^[A-Za-z0-9_]+$", max_length=EVENT_MAX))
SpeechView = _command_view(
    "SpeechView", action="speech", field="text", command=_value_only(tool.say), summary="Speak",
    description="Text to speech (trimmed, 1-500 characters); requests queue on the robot.",
    input_field=serializers.CharField(max_length=SPEECH_MAX))
EmotionView = _command_view(
    "EmotionView", action="emotion", field="emotion", command=_value_only(tool.set_emotion), summary="Set emotion",
    description="One of the emotion presets (managed in the admin).", input_field=serializers.CharField())
EmotionSystemView = _command_view(
    "EmotionSystemView", action="emotion_system", field="on", command=_value_only(tool.set_emotion_system),
    summary="Emotion system", description="Switch the emotion system on or off.",
    input_field=serializers.BooleanField())
MotorsView = _command_view(
    "MotorsView", action="motors", field="enabled", command=_value_only(motors.set_motors), summary="Motors",
    description="Enable or disable the motors through the RosAria services; 502 carries the service's error.",
    input_field=serializers.BooleanField(), errors=(502,))
PlaybackView = _command_view(
    "PlaybackView", action="playback", field="clip", command=_value_only(tool.play_clip), summary="Play sound",
    description="Play one of the sound clips (managed in the admin).", input_field=serializers.CharField())
DomeView = _command_view(
    "DomeView", action="dome", field="mode", command=_value_only(tool.set_dome), summary="Dome mode",
    description="Set the LED dome's visual mode (managed in the admin).", input_field=serializers.CharField())
