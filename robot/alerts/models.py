"""Alerts and their history (the ``robot`` app's models: robot/models.py imports these)."""

from __future__ import annotations

import uuid

from django.conf import settings
from django.db import models


class Alert(models.Model):
    """One alert from when it began to when it ended: raised by the robot link (robot.alerts.engine)."""

    class Severity(models.TextChoices):
        WARNING = "warning"
        ERROR = "error"
        CRITICAL = "critical"

    id = models.UUIDField(primary_key=True, default=uuid.uuid4, editable=False)
    key = models.CharField(max_length=200, db_index=True, help_text="What raised it: offline, log:/node, diag:name…")
    kind = models.CharField(max_length=32, db_index=True)
    severity = models.CharField(max_length=16, choices=Severity.choices)
    text = models.TextField()
    started_at = models.DateTimeField(db_index=True)
    updated_at = models.DateTimeField()
    ended_at = models.DateTimeField(null=True, blank=True, db_index=True)
    count = models.PositiveIntegerField(default=1, help_text="How many times it was raised while it lasted.")
    acked_at = models.DateTimeField(null=True, blank=True)
    acked_by = models.ForeignKey(settings.AUTH_USER_MODEL, null=True, blank=True, on_delete=models.SET_NULL,
                                 related_name="+")
    acked_by_name = models.CharField(max_length=150, blank=True)

    class Meta:
        ordering = ["-started_at"]

    def __str__(self) -> str:
        return f"{self.severity}: {self.text}"


# Every kind of alert, as a person chooses them (robot.alerts.rules raises these).
KINDS: dict[str, str] = {
    "offline": "Robot offline",
    "not_responding": "Robot not responding",
    "battery_low": "Battery low",
    "log": "ERROR and FATAL lines in the robot log",
    "diagnostics": "Diagnostics WARN, ERROR or STALE",
    "bumper": "Bumper pressed",
    "estop": "E-STOP engaged",
    "link_down": "No robot link runs (raised by the worker)",
}
LINK_DOWN = "link_down"
SEVERITY_RANK = {"warning": 1, "error": 2, "critical": 3}


class AlertChoice(models.Model):
    """Which alerts reach one person outside the page, and how."""

    user = models.OneToOneField(settings.AUTH_USER_MODEL, on_delete=models.CASCADE, related_name="alert_choice")
    by_email = models.BooleanField(default=False)
    by_push = models.BooleanField(default=False)
    kinds = models.JSONField(default=list, blank=True, help_text="Kinds of alert to send (empty: none).")
    min_severity = models.CharField(max_length=16, choices=Alert.Severity.choices, default=Alert.Severity.WARNING)
    email = models.EmailField(blank=True, help_text="The person's own address for alerts, kept once they opened "
                              "the link mailed to it (robot.alerts.addresses); empty: their account's address.")

    def __str__(self) -> str:
        return f"alerts for {self.user}"

    @property
    def address(self) -> str:
        """Where this person's alerts go by e-mail: their verified own address, else the account's
        (set by an admin or the sign-in provider)."""
        return self.email or self.user.email

    def wants(self, kind: str, severity: str) -> bool:
        return kind in self.kinds and SEVERITY_RANK.get(severity, 0) >= SEVERITY_RANK[self.min_severity]


class PushSubscription(models.Model):
    """One browser's Web Push subscription (its endpoint and keys), for one person."""

    user = models.ForeignKey(settings.AUTH_USER_MODEL, on_delete=models.CASCADE, related_name="push_subscriptions")
    endpoint = models.URLField(max_length=1000, unique=True)
    p256dh = models.CharField(max_length=200)
    auth = models.CharField(max_length=100)
    created = models.DateTimeField(auto_now_add=True)

    def __str__(self) -> str:
        return self.endpoint[:80]


class Webhook(models.Model):
    """A chat tool or other service that gets each alert as a JSON POST (admins add them)."""

    name = models.CharField(max_length=100)
    url = models.URLField(max_length=1000)
    enabled = models.BooleanField(default=True)
    kinds = models.JSONField(default=list, blank=True, help_text=f"Kinds to send, of: {', '.join(KINDS)}. "
                             "Empty: every kind.")
    min_severity = models.CharField(max_length=16, choices=Alert.Severity.choices, default=Alert.Severity.WARNING)

    def __str__(self) -> str:
        return self.name

    def wants(self, kind: str, severity: str) -> bool:
        return (not self.kinds or kind in self.kinds) and \
            SEVERITY_RANK.get(severity, 0) >= SEVERITY_RANK[self.min_severity]
