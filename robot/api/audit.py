"""GET /api/audit/: the command log, newest first. Every signed-in role may read it (it is
monitoring: viewers see what operators did); filters ?user= &action= &source= &outcome=ok|failed."""

from __future__ import annotations

from datetime import UTC

from django.db.models import QuerySet
from drf_spectacular.utils import OpenApiParameter, extend_schema
from rest_framework import generics, serializers
from rest_framework.pagination import PageNumberPagination

from robot.api.base import API_AUTHENTICATION
from robot.commands.selectors import audit_entries
from robot.models import AuditEntry


class AuditEntryOut(serializers.ModelSerializer):
    created = serializers.DateTimeField(read_only=True, default_timezone=UTC)  # APIs speak UTC

    class Meta:
        model = AuditEntry
        fields = ["id", "created", "username", "address", "source", "action", "params", "ok", "outcome",
                  "error_code"]


class AuditPagination(PageNumberPagination):
    page_size = 50
    page_size_query_param = "page_size"
    max_page_size = 500


@extend_schema(
    summary="Command log", tags=["audit"],
    parameters=[
        OpenApiParameter("user", str, description="Username"),
        OpenApiParameter("action", str, description="mode, event, speech, emotion, motors…"),
        OpenApiParameter("source", str, enum=[s.value for s in AuditEntry.Source]),
        OpenApiParameter("outcome", str, enum=["ok", "failed"]),
    ],
)
class AuditListView(generics.ListAPIView):
    authentication_classes = API_AUTHENTICATION
    serializer_class = AuditEntryOut
    pagination_class = AuditPagination

    def get_queryset(self) -> QuerySet[AuditEntry]:
        return audit_entries(self.request.query_params)
