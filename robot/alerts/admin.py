"""Admin → Alerts: the history (read only), each person's choices, push subscriptions, webhooks."""

from __future__ import annotations

from typing import Any

from django.contrib import admin
from django.http import HttpRequest

from robot.alerts.models import Alert, AlertChoice, PushSubscription, Webhook


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


@admin.register(Webhook)
class WebhookAdmin(admin.ModelAdmin):
    list_display = ("name", "url", "enabled", "kinds", "min_severity")


@admin.register(AlertChoice)
class AlertChoiceAdmin(admin.ModelAdmin):
    list_display = ("user", "by_email", "by_push", "kinds", "min_severity")


@admin.register(PushSubscription)
class PushSubscriptionAdmin(admin.ModelAdmin):
    list_display = ("user", "endpoint", "created")
    readonly_fields = ("user", "endpoint", "p256dh", "auth", "created")

    def has_add_permission(self, request: HttpRequest) -> bool:
        return False
