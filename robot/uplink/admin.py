from __future__ import annotations

from typing import Any

from django.contrib import admin, messages
from django.db.models import QuerySet
from django.http import HttpRequest

from robot.models import UplinkCredential
from robot.uplink.credentials import credential_issue, credential_revoke, credential_rotate

_SHOWN_ONCE = "Copy it into the robot's uplink environment now (UPLINK_CREDENTIAL); it is not shown again: "


@admin.register(UplinkCredential)
class UplinkCredentialAdmin(admin.ModelAdmin):
    list_display = ("robot", "label", "key_id", "created", "rotated", "revoked", "last_used", "last_address")
    list_filter = ("robot",)
    readonly_fields = ("key_id", "created", "rotated", "revoked", "last_used", "last_address")
    actions = ("rotate", "revoke")

    def get_fields(self, request: HttpRequest, obj: Any = None) -> list[Any]:
        return ["robot", "label"] if obj is None else ["robot", "label", *self.readonly_fields]

    def get_readonly_fields(self, request: HttpRequest, obj: Any = None) -> tuple[str, ...]:
        return self.readonly_fields + (("robot",) if obj is not None else ())

    def save_model(self, request: HttpRequest, obj: UplinkCredential, form: Any, change: bool) -> None:
        text = None if change else credential_issue(credential=obj)
        super().save_model(request, obj, form, change)
        if text is not None:
            messages.warning(request, f"Uplink credential for {obj.robot} made. {_SHOWN_ONCE}{text}")

    @admin.action(description="Rotate: a new secret (the old one and its live uplink stop at once)")
    def rotate(self, request: HttpRequest, queryset: QuerySet[UplinkCredential]) -> None:
        for credential in queryset.filter(revoked__isnull=True):
            messages.warning(request, f"{credential.robot} {credential.key_id} rotated. "
                                      f"{_SHOWN_ONCE}{credential_rotate(credential=credential)}")

    @admin.action(description="Revoke (its live uplink closes within a second)")
    def revoke(self, request: HttpRequest, queryset: QuerySet[UplinkCredential]) -> None:
        for credential in queryset:
            credential_revoke(credential=credential)
        messages.success(request, f"Revoked {queryset.count()} uplink credential(s).")
