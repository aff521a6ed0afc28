from django.conf import settings
from django.db import models


class UserPreference(models.Model):
    """One page setting a person chose (e.g. which map overlays are on), kept across browsers."""

    user = models.ForeignKey(settings.AUTH_USER_MODEL, on_delete=models.CASCADE, related_name="preferences")
    name = models.CharField(max_length=64)
    value = models.JSONField(default=dict)
    updated = models.DateTimeField(auto_now=True)

    class Meta:
        constraints = [models.UniqueConstraint(fields=["user", "name"], name="one_preference_per_name")]

    def __str__(self) -> str:
        return f"{self.user} {self.name}"
