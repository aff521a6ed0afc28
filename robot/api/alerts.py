"""Alerts: the ones on now, their history, and acknowledging one (thin: robot.alerts does the work)."""

from __future__ import annotations

from asgiref.sync import async_to_sync
from drf_spectacular.utils import OpenApiParameter, extend_schema, inline_serializer
from rest_framework import serializers
from rest_framework.request import Request
from rest_framework.response import Response

from robot.alerts.choices import alert_choice, alert_choice_set, push_subscribe, push_unsubscribe
from robot.alerts.selectors import alerts_history, alerts_on
from robot.alerts.services import alert_acknowledge
from robot.api.base import robot_api_view
from robot.api.common import error_responses, same, shape
from robot.api.validation import body_object

AlertOut = shape(
    "AlertOut", **same(serializers.CharField, "id", "key", "kind", "severity", "text"),
    started_at=serializers.FloatField(help_text="epoch seconds"), updated_at=serializers.FloatField(),
    ended_at=serializers.FloatField(allow_null=True), count=serializers.IntegerField(),
    acked_by=serializers.CharField(), acked_at=serializers.FloatField(allow_null=True))
Alerts = inline_serializer(name="Alerts", fields={"on": AlertOut(many=True), "history": AlertOut(many=True)})


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
    return Response(alert_acknowledge(user=request.user, alert_id=alert_id))


_CHOICE = {**same(serializers.BooleanField, "by_email", "by_push"),
           "kinds": serializers.ListField(child=serializers.CharField()), "min_severity": serializers.CharField()}
Choice = inline_serializer(name="AlertChoice", fields=dict(_CHOICE))  # (DRF takes the fields out of the dict)
ChoiceOut = inline_serializer(name="AlertChoiceOut", fields={
    **_CHOICE, "email": serializers.CharField(),
    "kinds_available": serializers.DictField(child=serializers.CharField()),
    "push_public_key": serializers.CharField(help_text="the VAPID applicationServerKey (base64url)"),
    "push_browsers": serializers.IntegerField()})


@extend_schema(methods=["GET"], responses={200: ChoiceOut}, summary="Which alerts reach you outside the page")
@extend_schema(methods=["PATCH"], request=Choice, responses={200: ChoiceOut, **error_responses(400)},
               summary="Choose which alerts reach you (e-mail, Web Push) and from which severity")
@robot_api_view(["GET", "PATCH"])
def alert_choice_view(request: Request) -> Response:
    if request.method == "PATCH":
        return Response(alert_choice_set(request.user, body_object(request)))
    return Response(alert_choice(request.user))


Subscription = inline_serializer(name="PushSubscription", fields={
    "endpoint": serializers.URLField(), "keys": serializers.DictField(child=serializers.CharField())})


@extend_schema(methods=["POST"], request=Subscription, responses={204: None, **error_responses(400)},
               summary="Get Web Push alerts in this browser (its PushSubscription)")
@extend_schema(methods=["DELETE"], request=Subscription, responses={204: None},
               summary="Stop Web Push alerts in this browser")
@robot_api_view(["POST", "DELETE"])
def push_subscription_view(request: Request) -> Response:
    data = body_object(request)
    if request.method == "DELETE":
        push_unsubscribe(request.user, data.get("endpoint"))
    else:
        push_subscribe(request.user, data)
    return Response(status=204)
