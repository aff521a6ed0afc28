"""One error shape for the whole API: {"detail": message, "code": code[, "field": name]}."""

from __future__ import annotations

from rest_framework import exceptions, status
from rest_framework.response import Response
from rest_framework.views import exception_handler

from robot.bus import RobotError


def api_exception_handler(exc, context):
    if isinstance(exc, RobotError):
        body = {"detail": exc.message, "code": exc.code}
        if getattr(exc, "field", None):
            body["field"] = exc.field
        return Response(body, status=exc.status_code)
    if isinstance(exc, exceptions.ValidationError) and isinstance(exc.detail, dict):
        field, messages = next(iter(exc.detail.items()))
        message = messages[0] if isinstance(messages, list) and messages else messages
        if isinstance(message, dict):  # nested serializer
            message = next(iter(message.values()))
            message = message[0] if isinstance(message, list) else message
        label = "Invalid input" if field == "non_field_errors" else f"{field}: {message}"
        body = {"detail": label if field != "non_field_errors" else str(message), "code": "invalid", "field": field,
                "errors": exc.detail}
        return Response(body, status=status.HTTP_400_BAD_REQUEST)
    response = exception_handler(exc, context)
    if response is not None and isinstance(response.data, dict) and "detail" in response.data:
        response.data["code"] = getattr(exc, "default_code", "error")
    return response
