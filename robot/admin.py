import math
from typing import Any

from django import forms
from django.contrib import admin
from django.http import HttpRequest

from robot.models import AuditEntry, DomeMode, EmotionPreset, FrontDoorAllowance, FrontDoorPace, Location, SoundClip


@admin.register(AuditEntry)
class AuditEntryAdmin(admin.ModelAdmin):
    list_display = ("created", "username", "address", "source", "action", "ok", "outcome")
    list_filter = ("ok", "source", "action")
    search_fields = ("username", "action", "outcome")
    date_hierarchy = "created"
    readonly_fields = [f.name for f in AuditEntry._meta.fields]

    def has_add_permission(self, request: HttpRequest) -> bool:
        return False

    def has_change_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False


@admin.register(EmotionPreset)
class EmotionPresetAdmin(admin.ModelAdmin):
    list_display = ("name", "pleasure", "arousal", "dominance", "description")
    search_fields = ("name",)


@admin.register(SoundClip)
class SoundClipAdmin(admin.ModelAdmin):
    list_display = ("name", "label", "description")


@admin.register(FrontDoorAllowance)
class FrontDoorAllowanceAdmin(admin.ModelAdmin):
    """What ROS tools' operators may further publish or call (open tools hear a change within a second)."""

    list_display = ("kind", "name")
    list_filter = ("kind",)


@admin.register(FrontDoorPace)
class FrontDoorPaceAdmin(admin.ModelAdmin):
    """How often a tool asking no throttle gets a topic (open tools hear a change within a second)."""

    list_display = ("topic", "hz")


@admin.register(DomeMode)
class DomeModeAdmin(admin.ModelAdmin):
    list_display = ("name", "label", "description")


class LocationForm(forms.ModelForm):
    """People read headings in degrees (as on the map page); the robot and the API use radians."""

    heading_deg = forms.FloatField(
        label="Heading (°)", initial=0.0, min_value=-360.0, max_value=360.0,
        help_text="Degrees, counter-clockwise from the map's x axis (as on the map page).")

    class Meta:
        model = Location
        fields = ("name", "map_name", "x", "y", "heading_deg", "threshold", "description")

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        if self.instance.pk is not None:
            self.initial["heading_deg"] = round(math.degrees(self.instance.yaw), 1)
            for name in ("x", "y", "threshold"):  # millimetres: what a map shows and a robot reaches
                self.initial[name] = round(getattr(self.instance, name), 3)

    def save(self, commit: bool = True) -> Location:
        self.instance.yaw = math.radians(self.cleaned_data["heading_deg"])
        return super().save(commit)


@admin.register(Location)
class LocationAdmin(admin.ModelAdmin):
    form = LocationForm
    fields = LocationForm.Meta.fields
    list_display = ("name", "map_name", "x_m", "y_m", "heading", "threshold")
    search_fields = ("name", "description")

    @admin.display(description="x (m)", ordering="x")
    def x_m(self, location: Location) -> str:
        return f"{location.x:.3f}"

    @admin.display(description="y (m)", ordering="y")
    def y_m(self, location: Location) -> str:
        return f"{location.y:.3f}"

    @admin.display(description="Heading (°)", ordering="yaw")
    def heading(self, location: Location) -> str:
        return f"{math.degrees(location.yaw):.0f}"

from robot.uplink import admin as _uplink_admin  # noqa: E402,F401  (registers the uplink credentials)
