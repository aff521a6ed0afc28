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


def _tool(action: str) -> Callable[[Any, Any], Command]:
    return lambda value, user: tool.string_command(action, value)


class FieldCommandView(CommandAPIView):
    action_name: ClassVar[str]
    field: ClassVar[str]
    command: ClassVar[Callable[[Any, Any], Command]]  # (value, user) -> the command

    def post(self, request: Request) -> Response:
        data = body_object(request)
        reject_unknown(data, [self.field])
        outcome = run(request, type(self).command(data.get(self.field), request.user))
        return Response({"ok": True, "action": self.action_name, "outcome": outcome})


def _command_view(name: str, *, field: str, command: Callable[[Any, Any], Command], summary: str, description: str,
                  input_field: serializers.Field, errors: tuple[int, ...] = ()) -> type[FieldCommandView]:
    """One view per command, ``POST /api/robot/<name>/``: the class, and its OpenAPI description."""
    title = "".join(part.title() for part in name.split("-"))  # "emotion-system": EmotionSystemView
    view = type(f"{title}View", (FieldCommandView,), {"action_name": name.replace("-", "_"), "field": field,
                                                      "command": staticmethod(command), "__doc__": description})
    return extend_schema(
        summary=summary, description=description, tags=["commands"],
        request=inline_serializer(f"{title}In", {field: input_field}),
        responses={200: CommandOut, **error_responses(400, 401, 403, 409, 429, 503, 504, *errors)},
    )(view)


# The command views by name: the URL path and name ("api-robot-<name>") and the pages' data-command.
COMMAND_VIEWS = {view.action_name.replace("_", "-"): view for view in (
    _command_view(
        "mode", field="mode", summary="Change mode",
        command=lambda mode, user: modes.change_mode(mode, user=user),
        description="Behaviour, Demo, Manual or Stop. With `MODE_COMMANDER=server` the server runs the commander's "
                    "sequence itself; with `robot` it publishes the mode on `robot_mode`. One change at a time (409).",
        input_field=serializers.ChoiceField(choices=MODE_NAMES)),
    _command_view(
        "event", field="event", command=_tool("event"), summary="Send event",
        description="Register a state machine event (see `available_events` in the robot state).",
        input_field=serializers.RegexField(r"^[A-Za-z0-9_]+$", max_length=EVENT_MAX)),
    _command_view(
        "speech", field="text", command=_tool("speech"), summary="Speak",
        description="Text to speech (trimmed, 1-500 characters); requests queue on the robot.",
        input_field=serializers.CharField(max_length=SPEECH_MAX)),
    _command_view(
        "emotion", field="emotion", command=_tool("emotion"), summary="Set emotion",
        description="One of the emotion presets (managed in the admin).", input_field=serializers.CharField()),
    _command_view(
        "emotion-system", field="on", command=_tool("emotion_system"), summary="Emotion system",
        description="Switch the emotion system on or off.", input_field=serializers.BooleanField()),
    _command_view(
        "motors", field="enabled", command=lambda enabled, user: motors.set_motors(enabled), summary="Motors",
        description="Enable or disable the motors through the RosAria services; 502 carries the service's error.",
        input_field=serializers.BooleanField(), errors=(502,)),
    _command_view(
        "playback", field="clip", command=_tool("playback"), summary="Play sound",
        description="Play one of the sound clips (managed in the admin).", input_field=serializers.CharField()),
    _command_view(
        "dome", field="mode", command=_tool("dome"), summary="Dome mode",
        description="Set the LED dome's visual mode (managed in the admin).", input_field=serializers.CharField()),
)}
