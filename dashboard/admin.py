"""People in the admin: their single sign-on identity, and logging a person out everywhere at once."""

from __future__ import annotations

from typing import Any

from django.contrib import admin, messages
from django.contrib.auth import get_user_model
from django.contrib.auth.admin import UserAdmin
from django.db.models import QuerySet
from django.http import HttpRequest

from dashboard.models import SsoIdentity
from dashboard.sessions import end_sessions_and_tokens
from robot.commands.audit import audit_record

User = get_user_model()


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
    actions = (end_sessions,)
    fieldsets = (*(UserAdmin.fieldsets or ()), ("Single sign-on", {"fields": ("single_sign_on",)}))
    readonly_fields = ("single_sign_on",)

    @admin.display(description="Identity")
    def single_sign_on(self, user: Any) -> str:
        identity = SsoIdentity.objects.filter(user=user).first()
        if identity is None:
            return "None: a local account"
        return (f"{identity.subject} at {identity.issuer}; the provider's claims gave {identity.role or 'no role'} "
                f"at the last login ({identity.last_login:%Y-%m-%d %H:%M})")


admin.site.unregister(User)
admin.site.register(User, PersonAdmin)
