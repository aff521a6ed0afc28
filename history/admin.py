"""Admins edit recording policies here; changes reach the recorder within ~1 s, no restart."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from typing import Any

from django.contrib import admin, messages
from django.db import transaction
from django.db.models import Max, Min, QuerySet
from django.http import HttpRequest, HttpResponse
from django.shortcuts import redirect
from django.urls import path
from django.utils.html import format_html

from history.durations import DurationInSeconds
from history.incidents import incident_release
from history.models import Incident, Mode, RecordingSettings, Sample, TopicPolicy
from history.policies import policies_discover
from history.policy_audit import default_interval_audited, policies_audited
from history.storage import samples_deleted
from robot.link.bus import RobotError


@admin.register(RecordingSettings)
class RecordingSettingsAdmin(admin.ModelAdmin):
    list_display = ("__str__", "default_interval_s", "effective_interval_s")

    def has_add_permission(self, request: HttpRequest) -> bool:
        return not RecordingSettings.objects.exists()

    def has_delete_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False

    def save_model(self, request: HttpRequest, obj: Any, form: Any, change: bool) -> None:
        with default_interval_audited(user=request.user, source="page"):
            super().save_model(request, obj, form, change)


def _audited(request: HttpRequest, topics: list[str]) -> AbstractContextManager[None]:
    """What the block changes of ``topics``' policies, audited as done on the admin pages."""
    return policies_audited(user=request.user, source="page", topics=topics)


def _set_mode(mode: str) -> Callable[[Any, HttpRequest, QuerySet[TopicPolicy]], None]:
    @admin.action(description=f"Record selected topics: {Mode(mode).label}")
    def action(modeladmin: Any, request: HttpRequest, queryset: QuerySet[TopicPolicy]) -> None:
        with _audited(request, list(queryset.values_list("topic", flat=True))):
            count = queryset.update(mode=mode)
        modeladmin.message_user(request, f"{count} topic(s) now recorded: {Mode(mode).label}.")

    action.__name__ = f"set_mode_{mode}"
    return action


@admin.register(TopicPolicy)
class TopicPolicyAdmin(admin.ModelAdmin):
    # Few, narrow columns: the list (with the filter beside it) fits a 1366 px screen.
    list_display = ("topic_and_type", "mode", "interval_s", "retention_s", "sensitive")
    list_display_links = ("topic_and_type",)
    list_editable = ("mode", "interval_s", "retention_s", "sensitive")
    ordering = ("topic",)
    list_filter = ("mode", "sensitive")
    search_fields = ("topic", "msg_type")
    actions = [_set_mode(m) for m in Mode.values]
    change_list_template = "history/admin_policy_changelist.html"

    class Media:
        css = {"all": ("css/admin_policies.css",)}

    @admin.display(description="Topic", ordering="topic")
    def topic_and_type(self, policy: TopicPolicy) -> str:
        return format_html('{}<br><small class="policy-type">{}</small>', policy.topic, policy.msg_type)

    def formfield_for_dbfield(self, db_field: Any, request: HttpRequest, **kwargs: Any) -> Any:
        if db_field.name == "retention_s":  # "30 d", not 2592000.0 (the list's inline edits too)
            return DurationInSeconds(required=False, label="Retention",
                                     help_text="Delete samples older than this (30 d, 12 h, 90 min); empty = keep.")
        return super().formfield_for_dbfield(db_field, request, **kwargs)

    def save_model(self, request: HttpRequest, obj: Any, form: Any, change: bool) -> None:
        # (the list's inline edits come here too, one policy at a time)
        topics = [obj.topic, *([form.initial["topic"]] if change and form.initial.get("topic") else [])]
        with _audited(request, list(dict.fromkeys(topics))):
            super().save_model(request, obj, form, change)

    def delete_model(self, request: HttpRequest, obj: Any) -> None:
        with _audited(request, [obj.topic]):
            super().delete_model(request, obj)

    def delete_queryset(self, request: HttpRequest, queryset: QuerySet[TopicPolicy]) -> None:
        with _audited(request, list(queryset.values_list("topic", flat=True))):
            super().delete_queryset(request, queryset)

    def get_urls(self) -> list[Any]:
        custom = [path("discover/", self.admin_site.admin_view(self.discover), name="history_topicpolicy_discover")]
        return custom + super().get_urls()

    def discover(self, request: HttpRequest) -> HttpResponse:
        """Add (mode off) every topic the robot reports through /rosapi/topics."""
        if request.method == "POST" and self.has_add_permission(request):
            try:
                discovered, added = policies_discover(user=request.user, source="page")
            except RobotError as exc:
                self.message_user(request, f"Could not ask the robot for its topics: {exc.message}", messages.ERROR)
            else:
                self.message_user(request, f"The robot reports {discovered} topics; added {len(added)} new "
                                           "(recording off).")
        return redirect("admin:history_topicpolicy_changelist")


class _ReadOnlyAdmin(admin.ModelAdmin):
    """Rows the server makes: an admin reads them (and deletes or releases), never adds or edits one."""

    def has_add_permission(self, request: HttpRequest) -> bool:
        return False

    def has_change_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False


@admin.register(Sample)
class SampleAdmin(_ReadOnlyAdmin):
    list_display = ("topic", "msg_type", "received_at")
    search_fields = ("topic",)
    show_full_result_count = False  # counting millions of rows on every page view is slow

    def delete_model(self, request: HttpRequest, obj: Sample) -> None:
        self.delete_queryset(request, Sample.objects.filter(pk=obj.pk))

    def delete_queryset(self, request: HttpRequest, queryset: QuerySet[Sample]) -> None:
        """Delete, then rebuild the rollups the deleted samples were in."""
        with transaction.atomic():
            spans = list(queryset.order_by().values("topic").annotate(lo=Min("received_at"), hi=Max("received_at")))
            queryset.delete()
            for span in spans:
                samples_deleted(topic=span["topic"], start=span["lo"].timestamp(), end=span["hi"].timestamp())


@admin.register(Incident)
class IncidentAdmin(_ReadOnlyAdmin):
    """Incidents are made by the black box; an admin only reads them and releases them to retention."""

    list_display = ("t", "kind", "summary", "by", "driver", "complete", "held", "released_by")
    list_filter = ("kind", "held", "complete")
    actions = ["release"]

    @admin.action(description="Release to retention (its samples and frames age like the rest)")
    def release(self, request: HttpRequest, queryset: QuerySet[Incident]) -> None:
        for incident in queryset.filter(held=True):
            incident_release(incident=incident, by=request.user.get_username())
        self.message_user(request, "Released: retention may now delete what they held.", messages.SUCCESS)
