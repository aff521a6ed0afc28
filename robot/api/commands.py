"""POST endpoints that command the robot; one view per command, all thin.

Validation lives in the command functions (one path for page, API and websocket, audited
either way); the serializers here describe the input for the OpenAPI schema.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any, ClassVar

from asgiref.sync import async_to_sync
from drf_spectacular.utils import extend_schema, inline_serializer
from rest_framework import serializers
from rest_framework.response import Response
from rest_framework.views import APIView

from robot.api.common import API_AUTHENTICATION, CommandThrottle, error_responses, source_of
from robot.commands import modes, motors, tool
from robot.commands.validation import EVENT_MAX, MODE_NAMES, SPEECH_MAX

CommandOut = inline_serializer("CommandResult", {
    "ok": serializers.BooleanField(),
    "action": serializers.CharField(),
    "outcome": serializers.CharField(help_text="What was done, for a person."),
})


class _CommandView(APIView):
    authentication_classes = API_AUTHENTICATION
    throttle_classes = [CommandThrottle]
    throttle_scope = "commands"
    action_name: ClassVar[str]
    field: ClassVar[str]
    command: ClassVar[Callable[..., Awaitable[str]]]

    def post(self, request) -> Response:
        data: dict[str, Any] = request.data if isinstance(request.data, dict) else {}
        run = type(self).command
        outcome = async_to_sync(run)(user=request.user, source=source_of(request), **{self.field: data.get(self.field)})
        return Response({"ok": True, "action": self.action_name, "outcome": outcome})


def _doc(summary: str, description: str, fields: dict[str, serializers.Field], *errors: int):
    return extend_schema(
        summary=summary, description=description, tags=["commands"],
        request=inline_serializer(f"{summary.title().replace(' ', '')}In", fields),
        responses={200: CommandOut, **error_responses(400, 401, 403, 429, 503, 504, *errors)},
    )


@_doc("Change mode", "Behaviour, Demo, Manual or Stop. With `MODE_COMMANDER=server` the server runs the "
      "commander's sequence itself; with `robot` it publishes the mode on `robot_mode`.",
      {"mode": serializers.ChoiceField(choices=MODE_NAMES)}, 409)
class ModeView(_CommandView):
    action_name, field = "mode", "mode"
    command = staticmethod(modes.achange_mode)


@_doc("Send event", "Register a state machine event (see `available_events` in the robot state).",
      {"event": serializers.RegexField(r"^[A-Za-z0-9_]+$", max_length=EVENT_MAX)})
class EventView(_CommandView):
    action_name, field = "event", "event"
    command = staticmethod(tool.asend_event)


@_doc("Speak", "Text to speech; requests queue on the robot.",
      {"text": serializers.CharField(max_length=SPEECH_MAX)})
class SpeechView(_CommandView):
    action_name, field = "speech", "text"
    command = staticmethod(tool.asay)


@_doc("Set emotion", "One of the emotion presets (managed in the admin).", {"emotion": serializers.CharField()})
class EmotionView(_CommandView):
    action_name, field = "emotion", "emotion"
    command = staticmethod(tool.aset_emotion)


@_doc("Emotion system", "Switch the emotion system on or off.", {"on": serializers.BooleanField()})
class EmotionSystemView(_CommandView):
    action_name, field = "emotion_system", "on"
    command = staticmethod(tool.aset_emotion_system)


@_doc("Motors", "Enable or disable the motors through the RosAria services.",
      {"enabled": serializers.BooleanField()}, 502)
class MotorsView(_CommandView):
    action_name, field = "motors", "enabled"
    command = staticmethod(motors.aset_motors)


@_doc("Play sound", "Play one of the sound clips (managed in the admin).", {"clip": serializers.CharField()})
class PlaybackView(_CommandView):
    action_name, field = "playback", "clip"
    command = staticmethod(tool.aplay_clip)


@_doc("Dome mode", "Set the LED dome's visual mode (managed in the admin).", {"mode": serializers.CharField()})
class DomeView(_CommandView):
    action_name, field = "dome", "mode"
    command = staticmethod(tool.aset_dome)
