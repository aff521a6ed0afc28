"""An API token's own end, when its person chose one (robot.api.tokens reads it)."""

from __future__ import annotations

from django.db import models
from rest_framework.authtoken.models import Token


class TokenExpiry(models.Model):
    """When a token made on its person's account page ends; a token without one ends
    ``API_TOKEN_DAYS`` after it was made."""

    token = models.OneToOneField(Token, primary_key=True, on_delete=models.CASCADE, related_name="expiry")
    expires = models.DateTimeField()

    class Meta:
        app_label = "robot"
        verbose_name_plural = "token expiries"

    def __str__(self) -> str:
        return f"{self.token.user} until {self.expires:%Y-%m-%d %H:%M}"
