"""Recording policies, recorded samples, their rollups, camera frames and incidents."""

from __future__ import annotations

from django.conf import settings
from django.db import models


class RecordingSettings(models.Model):
    """The one row of global recording settings (edited in the admin, read at run time)."""

    default_interval_s = models.FloatField(
        default=0.0, help_text="Interval for periodic topics without their own. 0 = the server's default setting."
    )

    class Meta:
        verbose_name = verbose_name_plural = "recording settings"

    def __str__(self) -> str:
        return "Recording settings"

    @classmethod
    def load(cls) -> RecordingSettings:
        return cls.objects.get_or_create(pk=1)[0]

    @property
    def effective_interval_s(self) -> float:
        return self.default_interval_s if self.default_interval_s > 0 else settings.HISTORY_DEFAULT_INTERVAL_S


class Mode(models.TextChoices):
    OFF = "off", "off"
    EVERY = "every", "every message"
    PERIODIC = "periodic", "every N seconds"


class TopicPolicy(models.Model):
    topic = models.CharField(max_length=255, unique=True)
    msg_type = models.CharField(max_length=255, blank=True)
    mode = models.CharField(max_length=10, choices=Mode.choices, default=Mode.OFF)
    interval_s = models.FloatField(
        null=True, blank=True, help_text="Periodic topics only; empty = the global default interval."
    )
    retention_s = models.FloatField(null=True, blank=True, help_text="Delete samples older than this; empty = keep.")
    max_message_bytes = models.PositiveIntegerField(
        null=True, blank=True, help_text="Larger messages are not stored; empty = the server's default."
    )
    sensitive = models.BooleanField(
        default=False, help_text="Operators only: refused to viewers on the topics page, in history and exports. "
                                 "Sound (the microphone, the speaker) is always.")
    updated = models.DateTimeField(auto_now=True)

    class Meta:
        ordering = ["topic"]
        verbose_name_plural = "topic policies"

    def __str__(self) -> str:
        return f"{self.topic} ({self.mode})"


class Sample(models.Model):
    topic = models.CharField(max_length=255)
    msg_type = models.CharField(max_length=255)
    received_at = models.DateTimeField()
    data = models.JSONField()

    class Meta:
        indexes = [models.Index(fields=["topic", "received_at"], name="history_sample_topic_time")]

    def __str__(self) -> str:
        return f"{self.topic} @ {self.received_at.isoformat()}"


class Rollup(models.Model):
    """Min, max, sum and count of a numeric field over one second or minute (``slot`` = floor(epoch /
    level_s)), and the time of its first sample; kept at write time."""

    topic = models.CharField(max_length=255)
    field = models.CharField(max_length=255)
    t_first = models.FloatField(null=True)
    vmin = models.FloatField(null=True)
    vmax = models.FloatField(null=True)
    vsum = models.FloatField(null=True)
    n = models.IntegerField(default=0)
    level_s = models.IntegerField()
    slot = models.BigIntegerField()

    class Meta:
        constraints = [
            models.UniqueConstraint(fields=["topic", "level_s", "field", "slot"], name="history_rollup_unique")
        ]

    def __str__(self) -> str:
        return f"{self.topic} {self.field} [{self.level_s} s #{self.slot}]"


class Incident(models.Model):
    """A black box: everything from ``start`` to ``end`` around a trigger, kept at full rate."""

    class Kind(models.TextChoices):
        ESTOP = "estop", "E-STOP"
        BUMPER = "bumper", "bumper pressed"
        LOG_ERROR = "log_error", "ERROR/FATAL log line"
        DIAGNOSTICS = "diagnostics", "diagnostics ERROR"
        MANUAL = "manual", "marked moment"

    kind = models.CharField(max_length=16, choices=Kind.choices)
    t = models.FloatField(help_text="When it happened (epoch seconds).")
    start = models.FloatField()
    end = models.FloatField()
    summary = models.CharField(max_length=300, blank=True)
    # Later triggers of the same kind inside the window: [{"t", "summary"}], at most a few dozen.
    triggers = models.JSONField(default=list, blank=True)
    by = models.CharField(max_length=150, blank=True, help_text="Who pressed or marked it.")
    driver = models.CharField(max_length=150, blank=True, help_text="Who held the drive lock then.")
    complete = models.BooleanField(default=False, help_text="The window has passed and was captured.")
    held = models.BooleanField(default=True, help_text="Exempt from retention until an admin releases it.")
    released_by = models.CharField(max_length=150, blank=True)
    created = models.DateTimeField(auto_now_add=True)

    class Meta:
        ordering = ["-t"]
        indexes = [models.Index(fields=["complete", "end"], name="history_incident_open")]

    def __str__(self) -> str:
        return f"{self.get_kind_display()} at {self.t:.0f}"


class CameraFrame(models.Model):
    """One recorded camera frame; the JPEG itself is a file under ``CAMERA_RECORD_DIR``."""

    t = models.FloatField(db_index=True, help_text="Receive time (epoch seconds).")
    path = models.CharField(max_length=100, help_text="Relative to CAMERA_RECORD_DIR.")
    size = models.PositiveIntegerField()
    # Set on the frames kept at full rate for an incident (beyond the low-rate recording).
    incident = models.ForeignKey(Incident, null=True, blank=True, on_delete=models.SET_NULL)

    class Meta:
        ordering = ["t"]

    def __str__(self) -> str:
        return f"frame @ {self.t:.3f}"
