"""Request-body checks every command and navigation endpoint shares (400 naming the field)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from rest_framework import serializers
from rest_framework.request import Request


def body_object(request: Request) -> dict[str, Any]:
    """The body as a dict (JSON object or form); anything else is a 400, never a crash."""
    data = request.data
    if hasattr(data, "dict"):  # a form's QueryDict: one value per field
        return data.dict()
    if isinstance(data, dict):
        return data
    raise serializers.ValidationError({"body": ["must be a JSON object"]})


def reject_unknown(data: dict[str, Any], allowed: Iterable[str]) -> None:
    """Unknown fields are refused, so a misspelt field never silently falls back to a default."""
    known = set(allowed)
    unknown = sorted(str(key) for key in data if key not in known)
    if unknown:
        raise serializers.ValidationError(
            {unknown[0]: [f"unknown field; this takes {', '.join(sorted(known)) or 'no fields'}"]})
