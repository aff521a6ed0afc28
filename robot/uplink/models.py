from __future__ import annotations

from django.db import models


class UplinkCredential(models.Model):
    """What lets a robot's uplink agent in. Only a hash of its secret is kept; the whole credential is
    shown once, when it is made or rotated."""

    robot = models.CharField(max_length=64, default="cyborg", help_text="The robot this credential lets in "
                             "(the server takes its own robot's, UPLINK_ROBOT).")
    label = models.CharField(max_length=100, blank=True, help_text="Where it is installed, for people.")
    key_id = models.CharField(max_length=16, unique=True, editable=False)
    secret_sha256 = models.CharField(max_length=64, editable=False)
    created = models.DateTimeField(auto_now_add=True)
    rotated = models.DateTimeField(null=True, blank=True, editable=False)
    revoked = models.DateTimeField(null=True, blank=True, editable=False)
    last_used = models.DateTimeField(null=True, blank=True, editable=False)
    last_address = models.CharField(max_length=45, blank=True, editable=False)

    class Meta:
        app_label = "robot"
        ordering = ["robot", "-created"]

    def __str__(self) -> str:
        state = "revoked" if self.revoked else "active"
        return f"{self.robot} uplink {self.key_id} ({state})"
