from django.contrib import admin

from robot.models import AuditEntry, DomeMode, EmotionPreset, Location, SoundClip


@admin.register(AuditEntry)
class AuditEntryAdmin(admin.ModelAdmin):
    list_display = ("created", "username", "source", "action", "ok", "outcome")
    list_filter = ("ok", "source", "action")
    search_fields = ("username", "action", "outcome")
    date_hierarchy = "created"
    readonly_fields = [f.name for f in AuditEntry._meta.fields]

    def has_add_permission(self, request) -> bool:
        return False

    def has_change_permission(self, request, obj=None) -> bool:
        return False


@admin.register(EmotionPreset)
class EmotionPresetAdmin(admin.ModelAdmin):
    list_display = ("name", "pleasure", "arousal", "dominance", "description")
    search_fields = ("name",)


@admin.register(SoundClip)
class SoundClipAdmin(admin.ModelAdmin):
    list_display = ("name", "label", "description")


@admin.register(DomeMode)
class DomeModeAdmin(admin.ModelAdmin):
    list_display = ("name", "label", "description")


@admin.register(Location)
class LocationAdmin(admin.ModelAdmin):
    list_display = ("name", "map_name", "x", "y", "yaw", "threshold")
    search_fields = ("name", "description")
