"""What the robot API views document in the OpenAPI schema: the one error shape, and shapes of answers."""

from __future__ import annotations

from typing import Any

from drf_spectacular.utils import OpenApiResponse, inline_serializer
from rest_framework import serializers

ErrorOut = inline_serializer(
    name="Error",
    fields={
        "detail": serializers.CharField(help_text="What went wrong, for a person."),
        "code": serializers.CharField(help_text="invalid, forbidden, busy, offline, timeout, failed, throttled…"),
        "field": serializers.CharField(required=False, help_text="The input field at fault (400 only)."),
    },
)


def error_responses(*codes: int) -> dict[int, OpenApiResponse]:
    meaning = {
        400: "Invalid input; `field` names the field. Nothing was sent.",
        401: "Not authenticated.",
        403: "Your role may not command the robot (viewers). Nothing was sent.",
        404: "Not found (code `no_map`: no map from the robot yet).",
        409: "Refused for now: the E-STOP is engaged (code `estop`; an operator must release it) or another "
             "mode change is in progress (code `busy`). Nothing was sent.",
        429: "Too many commands; slow down.",
        502: "The robot refused (e.g. a failed service call).",
        503: "Robot offline. Nothing was sent or queued.",
        504: "The robot did not answer in time.",
    }
    return {code: OpenApiResponse(ErrorOut, description=meaning[code]) for code in codes}


def shape(name: str, /, **fields: serializers.Field) -> type[serializers.Serializer]:
    """An answer's shape for the schema: a serializer class (nestable, ``many=True``) that only documents."""
    return type(name, (serializers.Serializer,), fields)


def same(kind: type[serializers.Field], *names: str, **options: Any) -> dict[str, serializers.Field]:
    """Several fields of one kind: ``shape("Point", **same(serializers.FloatField, "x", "y"))``."""
    return {name: kind(**options) for name in names}
