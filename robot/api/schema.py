"""The OpenAPI schema documents every error an operation can answer, in the one error shape.

Views document their own meanings (``error_responses``); this adds the ones every view of a
kind shares: auth (401/403), bad input (400, 415), unknown objects (404), content
negotiation (406), throttling (429) and a backing service down (503).
"""

from __future__ import annotations

from typing import Any, Literal

from drf_spectacular.openapi import AutoSchema
from drf_spectacular.utils import OpenApiResponse
from rest_framework.permissions import AllowAny

from robot.api.common import ErrorOut

GENERIC_ERRORS = {
    400: "Invalid input (a body, field or query parameter); `field` names it. Nothing was done.",
    401: "Not authenticated: send `Authorization: Token <token>` (or sign in).",
    403: "Your role may not do this. Nothing was done.",
    404: "No such object.",
    406: "Cannot answer in the media type the Accept header asks for.",
    415: "Unsupported body media type (send application/json).",
    429: "Too many requests; wait for Retry-After seconds.",
    503: "Service unavailable: the database or Redis is down (the detail says which); retry shortly.",
}
BODY_METHODS = ("POST", "PUT", "PATCH")


class DocumentedErrorsSchema(AutoSchema):
    def _get_response_bodies(self, direction: Literal["request", "response"] = "response") -> Any:
        responses = super()._get_response_bodies(direction)
        for code in self._error_codes():
            if str(code) not in responses:
                documented = OpenApiResponse(ErrorOut, description=GENERIC_ERRORS[code])
                responses[str(code)] = self._get_response_for_code(documented, str(code), direction=direction)
        return responses

    def _error_codes(self) -> list[int]:
        codes = [400, 406, 503]
        if self.view.get_authenticators() and not any(
                isinstance(p, AllowAny) for p in self.view.get_permissions()):
            codes += [401, 403]
        if "{" in self.path or (self.method == "GET" and getattr(self.view, "pagination_class", None)):
            codes.append(404)  # no such object, or a page past the end
        if self.method in BODY_METHODS:
            codes.append(415)
        if self.view.get_throttles():
            codes.append(429)
        return codes
