"""Alerts: the ones on now, their history, and acknowledging one (thin: robot.alerts does the work)."""

from __future__ import annotations

from asgiref.sync import async_to_sync
from drf_spectacular.utils import OpenApiParameter, extend_schema, inline_serializer
from rest_framework import serializers
from rest_framework.request import Request
from rest_framework.response import Response

from robot.alerts.selectors import alerts_history, alerts_on
from robot.alerts.services import alert_acknowledge, atell_raiser
from robot.api.base import robot_api_view
from robot.api.common import error_responses

AlertOut = inline_serializer(name="Alert", fields={
    "id": serializers.CharField(), "key": serializers.CharField(), "kind": serializers.CharField(),
    "severity": serializers.CharField(), "text": serializers.CharField(),
    "started_at": serializers.FloatField(help_text="epoch seconds"), "updated_at": serializers.FloatField(),
    "ended_at": serializers.FloatField(allow_null=True), "count": serializers.IntegerField(),
    "acked_by": serializers.CharField(), "acked_at": serializers.FloatField(allow_null=True)})
Alerts = inline_serializer(name="Alerts", fields={"on": AlertOut, "history": AlertOut})


@extend_schema(responses={200: Alerts}, summary="The alerts on now, and the latest ones with their end",
               parameters=[OpenApiParameter("kind", str, description="only this kind (offline, log, …)")])
@robot_api_view(["GET"])
def alerts_view(request: Request) -> Response:
    kind = str(request.query_params.get("kind", ""))[:32]
    return Response({"on": async_to_sync(alerts_on)(), "history": alerts_history(kind=kind)})


@extend_schema(request=None, responses={200: AlertOut, **error_responses(403, 404)},
               summary="Acknowledge an alert (operators, admins); the first acknowledgement stands")
@robot_api_view(["POST"], commands=True)
def acknowledge_view(request: Request, alert_id: str) -> Response:
    alert = alert_acknowledge(user=request.user, alert_id=alert_id)
    async_to_sync(atell_raiser)(alert_id=alert["id"], by=alert["acked_by"], at=alert["acked_at"])
    return Response(alert)
