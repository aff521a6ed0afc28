"""The emergency stop over the API: ``POST /api/robot/estop/``."""

from __future__ import annotations

from asgiref.sync import async_to_sync
from drf_spectacular.utils import extend_schema
from rest_framework import serializers
from rest_framework.response import Response
from rest_framework.views import APIView

from robot.teleop.estop import STEPS, estop_run


class EstopStepSerializer(serializers.Serializer):
    step = serializers.ChoiceField(choices=[name for name, _ in STEPS])
    ok = serializers.BooleanField()
    detail = serializers.CharField()


class EstopOutputSerializer(serializers.Serializer):
    ok = serializers.BooleanField()
    steps = EstopStepSerializer(many=True)
    detail = serializers.CharField(required=False, help_text="Only when a step failed.")
    code = serializers.CharField(required=False, help_text="'partial' when a step failed.")


class EstopView(APIView):

    @extend_schema(
        request=None,
        responses={200: EstopOutputSerializer, 502: EstopOutputSerializer},
        summary="Emergency stop",
        description="Zero velocity (ending any teleop), cancel all navigation goals, disable the motors and "
        "switch to mode stop. Every step is attempted even if another fails; 502 when any step failed. "
        "Operators and admins only.",
    )
    def post(self, request):
        report = async_to_sync(estop_run)(user=request.user, source="api")
        body = report.as_dict()
        if not report.ok:
            body.update(detail="Emergency stop incomplete: " + report.summary(), code="partial")
        return Response(body, status=200 if report.ok else 502)
