"""The emergency stop over the API: ``GET|POST /api/robot/estop/``, ``POST /api/robot/estop/release/``.

Synchronous views, like every robot API view (see ``robot.api.base``): the role check and the
audit entry run in the request's thread, and the stop crosses to the event loop once —
its steps and the latch it leaves come back together in the command's ``result``.
"""

from __future__ import annotations

from asgiref.sync import async_to_sync
from drf_spectacular.utils import extend_schema
from rest_framework import serializers
from rest_framework.request import Request
from rest_framework.response import Response

from robot.api.base import RobotAPIView, run
from robot.api.common import error_responses, shape
from robot.estop.access import EstopAccessMixin
from robot.estop.latch import alatch
from robot.estop.stop import ORDER, EstopIncomplete, estop_command, estop_outcome, release_command

EstopStep = shape("EstopStep", step=serializers.ChoiceField(choices=["latch", *ORDER]),
                  ok=serializers.BooleanField(), detail=serializers.CharField())
EstopOutput = shape(
    "EstopOutput", ok=serializers.BooleanField(), steps=EstopStep(many=True),
    latch=serializers.DictField(help_text="The latch as every page sees it (see GET)."),
    detail=serializers.CharField(required=False, help_text="Only when a step failed."),
    code=serializers.CharField(required=False, help_text="'partial' when a step failed."))
Latch = shape(
    "Latch", latched=serializers.BooleanField(), by=serializers.CharField(help_text="Who pressed it."),
    at=serializers.FloatField(help_text="When (epoch seconds)."), at_text=serializers.CharField(),
    message=serializers.CharField(help_text='"E-STOP engaged by NAME at TIME" while latched.'),
    steps=EstopStep(many=True, help_text="What each step of the stop did."),
    released_by=serializers.CharField(), released_at=serializers.FloatField())
ReleaseInput = shape("ReleaseInput", confirm=serializers.BooleanField(
    help_text="Must be true: releasing lets the robot be driven again."))


class EstopView(EstopAccessMixin, RobotAPIView):  # never throttled: a stop always goes through

    @extend_schema(responses={200: Latch}, summary="E-STOP state")
    def get(self, request: Request) -> Response:
        return Response(async_to_sync(alatch)().as_msg())

    @extend_schema(
        request=None,
        responses={200: EstopOutput, 502: EstopOutput, **error_responses(401, 403)},
        summary="Emergency stop",
        description="Latch the stop, then: zero velocity (held for a moment, further motion refused), free and "
        "block the drive lock, cancel all navigation goals, disable the motors and switch to mode stop. Every step "
        "is attempted even if another fails; 502 when any failed, and the latch holds either way. While latched, "
        "driving, goals, initial pose, motors on and mode changes are refused with 409 until an operator releases "
        "it. Operators and admins only.",
    )
    def post(self, request: Request) -> Response:
        command = estop_command(request.user)
        try:
            run(request, command)
        except EstopIncomplete:
            pass  # every step was tried: the report says which failed
        report = estop_outcome(command)
        body = {**report.as_dict(), "latch": command.result["latch"].as_msg()}
        if not report.ok:
            body.update(detail="Emergency stop incomplete: " + report.summary(), code="partial")
        return Response(body, status=200 if report.ok else 502)


class EstopReleaseView(EstopAccessMixin, RobotAPIView):

    @extend_schema(
        request=ReleaseInput,
        responses={200: Latch, **error_responses(400, 401, 403)},
        summary="Release the E-STOP",
        description="An operator's explicit release, with confirm=true; audited. The motors stay off until "
        "someone turns them on.",
    )
    def post(self, request: Request) -> Response:
        confirm = request.data.get("confirm") if isinstance(request.data, dict) else None
        command = release_command(request.user, confirm)
        run(request, command)
        return Response(command.result["latch"].as_msg())
