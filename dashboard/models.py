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


class SsoIdentity(models.Model):
    """A person of the organisation's identity provider (issuer and subject) and the account they sign in to."""

    user = models.OneToOneField(settings.AUTH_USER_MODEL, on_delete=models.CASCADE, related_name="sso_identity")
    issuer = models.CharField(max_length=255)
    subject = models.CharField(max_length=255)
    role = models.CharField(max_length=16, blank=True,
                            help_text="The role the provider's claims gave at the last login.")
    last_login = models.DateTimeField(auto_now=True)

    class Meta:
        verbose_name = "single sign-on identity"
        constraints = [models.UniqueConstraint(fields=["issuer", "subject"], name="one_account_per_identity")]
        permissions = [("sign_in_with_password", "May sign in with a local password while single sign-on is required")]

    def __str__(self) -> str:
        return f"{self.user} ({self.issuer} {self.subject})"


class SessionRecord(models.Model):
    """One signed-in browser of a person, so they can see and end their sessions (Django's session
    store cannot be asked for one person's): made at login (dashboard.sessions), gone with the session."""

    user = models.ForeignKey(settings.AUTH_USER_MODEL, on_delete=models.CASCADE, related_name="session_records")
    session_key = models.CharField(max_length=40, unique=True)
    address = models.CharField(max_length=45, blank=True)
    user_agent = models.CharField(max_length=300, blank=True)
    created = models.DateTimeField(auto_now_add=True)
    last_seen = models.DateTimeField(auto_now_add=True)

    class Meta:
        ordering = ["-last_seen"]

    def __str__(self) -> str:
        return f"{self.user} from {self.address or '?'}"
