"""Admin → Alerts: the history (read only), each person's choices, push subscriptions, webhooks."""

from __future__ import annotations

import time
from typing import Any

from django import forms
from django.contrib import admin, messages
from django.db.models import QuerySet
from django.http import HttpRequest

from robot.alerts import delivery
from robot.alerts.book import Record
from robot.alerts.models import KINDS, Alert, AlertChoice, PushSubscription, Webhook


@admin.register(Alert)
class AlertAdmin(admin.ModelAdmin):
    list_display = ("started_at", "severity", "text", "count", "ended_at", "acked_by_name", "acked_at")
    list_filter = ("kind", "severity", ("ended_at", admin.EmptyFieldListFilter))
    search_fields = ("text", "key")
    date_hierarchy = "started_at"

    def has_add_permission(self, request: HttpRequest) -> bool:
        return False

    def has_change_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False


class WebhookForm(forms.ModelForm):
    kinds = forms.MultipleChoiceField(
        choices=list(KINDS.items()), required=False, widget=forms.CheckboxSelectMultiple,
        help_text="None ticked: every kind.")

    class Meta:
        model = Webhook
        fields = ("name", "url", "enabled", "kinds", "min_severity")


def webhook_test(hook: Webhook) -> str | None:
    """Send a test message to the webhook now, once; what went wrong, or None when it was taken."""
    now = time.time()
    record = Record(key="test", kind="test", severity="warning", started_at=now, updated_at=now,
                    text=f"Test message from Cyborg Commander for the webhook '{hook.name}'")
    try:
        delivery.send_webhook(hook.url, record)
    except Exception as exc:  # every failure is the outcome to show: refused, unreachable, timed out
        return str(exc) or type(exc).__name__
    return None


@admin.register(Webhook)
class WebhookAdmin(admin.ModelAdmin):
    form = WebhookForm
    list_display = ("name", "url", "enabled", "kinds", "min_severity")
    actions = ["send_test"]

    @admin.action(description="Send a test message to the selected webhooks")
    def send_test(self, request: HttpRequest, queryset: QuerySet[Webhook]) -> None:
        for hook in queryset:
            problem = webhook_test(hook)
            if problem is None:
                self.message_user(request, f"Test message sent to {hook.name} ({hook.url}).", messages.SUCCESS)
            else:
                self.message_user(request, f"Test message to {hook.name} ({hook.url}) failed: {problem}",
                                  messages.ERROR)


@admin.register(AlertChoice)
class AlertChoiceAdmin(admin.ModelAdmin):
    list_display = ("user", "by_email", "by_push", "kinds", "min_severity")


@admin.register(PushSubscription)
class PushSubscriptionAdmin(admin.ModelAdmin):
    list_display = ("user", "endpoint", "created")
    readonly_fields = ("user", "endpoint", "p256dh", "auth", "created")

    def has_add_permission(self, request: HttpRequest) -> bool:
        return False
