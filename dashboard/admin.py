"""People in the admin: their single sign-on identity, and logging a person out everywhere at once."""

from __future__ import annotations

from typing import Any

from django.contrib import admin, messages
from django.contrib.auth import get_user_model
from django.contrib.auth.admin import UserAdmin
from django.db.models import QuerySet
from django.http import HttpRequest

from dashboard.accounts import end_sessions_and_tokens
from dashboard.models import SsoIdentity
from robot.commands.audit import audit_record

User = get_user_model()


class SsoIdentityInline(admin.StackedInline):
    model = SsoIdentity
    can_delete = False
    readonly_fields = ("issuer", "subject", "role", "last_login")
    extra = 0

    def has_add_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False


@admin.action(description="End their sessions and API tokens now")
def end_sessions(modeladmin: admin.ModelAdmin, request: HttpRequest, queryset: QuerySet) -> None:
    for user in queryset:
        sessions, tokens = end_sessions_and_tokens(user)
        audit_record(user=request.user, source="page", action="account.sessions_ended",
                     params={"username": user.get_username()}, ok=True,
                     outcome=f"{sessions} sessions and {tokens} API tokens ended")
        modeladmin.message_user(
            request, f"{sessions} sessions and {tokens} API tokens of {user.get_username()} ended.", messages.SUCCESS)


class PersonAdmin(UserAdmin):
    inlines = (SsoIdentityInline,)
    actions = (end_sessions,)


admin.site.unregister(User)
admin.site.register(User, PersonAdmin)
