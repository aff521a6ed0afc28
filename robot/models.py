from django.conf import settings
from django.core.validators import MaxValueValidator, MinValueValidator, RegexValidator
from django.db import models
from rest_framework.authtoken.models import Token

_pad = [MinValueValidator(-1.0), MaxValueValidator(1.0)]
_slug = RegexValidator(r"^[A-Za-z0-9_\-]+$", "Use letters, digits, '_' and '-' only.")


class AuditEntry(models.Model):
    """One command someone (or something) sent to the robot, and what came of it."""

    class Source(models.TextChoices):
        PAGE = "page"
        API = "api"
        WEBSOCKET = "websocket"
        FRONTDOOR = "frontdoor"  # a ROS tool through the rosbridge front door
        SYSTEM = "system"

    created = models.DateTimeField(auto_now_add=True, db_index=True)
    user = models.ForeignKey(settings.AUTH_USER_MODEL, null=True, blank=True, on_delete=models.SET_NULL)
    username = models.CharField(max_length=150, blank=True)
    source = models.CharField(max_length=16, choices=Source.choices)
    action = models.CharField(max_length=64, db_index=True)
    params = models.JSONField(default=dict, blank=True)
    ok = models.BooleanField(default=False)
    outcome = models.TextField(blank=True)
    error_code = models.CharField(max_length=32, blank=True)
    address = models.CharField(max_length=45, blank=True, help_text="The client's address, as the server saw it.")

    class Meta:
        ordering = ["-created", "-id"]
        verbose_name_plural = "audit entries"

    def __str__(self) -> str:
        return f"{self.created:%Y-%m-%d %H:%M:%S} {self.username or '-'} {self.action} {'ok' if self.ok else 'failed'}"


class EmotionPreset(models.Model):
    name = models.CharField(max_length=64, unique=True, validators=[_slug])
    pleasure = models.FloatField(validators=_pad)
    arousal = models.FloatField(validators=_pad)
    dominance = models.FloatField(validators=_pad)
    description = models.CharField(max_length=200, blank=True)

    class Meta:
        ordering = ["name"]

    def __str__(self) -> str:
        return self.name


class NamedOption(models.Model):
    """A name the robot understands, with a friendly label for the pages."""

    name = models.CharField(max_length=64, unique=True, validators=[_slug])
    label = models.CharField(max_length=100, blank=True)
    description = models.CharField(max_length=200, blank=True)

    class Meta:
        abstract = True
        ordering = ["name"]

    def __str__(self) -> str:
        return self.label or self.name


class SoundClip(NamedOption):
    class Meta(NamedOption.Meta):
        pass


class DomeMode(NamedOption):
    class Meta(NamedOption.Meta):
        pass


class Location(models.Model):
    """A named place on a map the robot can be sent to."""

    name = models.CharField(max_length=64, unique=True, validators=[_slug])
    map_name = models.CharField(max_length=64, blank=True, default="")
    x = models.FloatField()
    y = models.FloatField()
    yaw = models.FloatField(default=0.0, help_text="Heading in radians.")
    threshold = models.FloatField(default=0.5, validators=[MinValueValidator(0.0)], help_text="Arrival radius (m).")
    description = models.CharField(max_length=200, blank=True)
    created = models.DateTimeField(auto_now_add=True)
    updated = models.DateTimeField(auto_now=True)

    class Meta:
        ordering = ["name"]

    def __str__(self) -> str:
        return self.name



class TokenExpiry(models.Model):
    """When a token made on its person's account page ends; a token without one ends
    ``API_TOKEN_DAYS`` after it was made."""

    token = models.OneToOneField(Token, primary_key=True, on_delete=models.CASCADE, related_name="expiry")
    expires = models.DateTimeField()

    class Meta:
        verbose_name_plural = "token expiries"

    def __str__(self) -> str:
        return f"{self.token.user} until {self.expires:%Y-%m-%d %H:%M}"


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
        ordering = ["robot", "-created"]

    def __str__(self) -> str:
        state = "revoked" if self.revoked else "active"
        return f"{self.robot} uplink {self.key_id} ({state})"


class ConnectTicket(models.Model):
    """A short-lived, single-use ticket that lets one ROS tool's websocket in through the front door.
    Only a hash of it is kept; it works once, within seconds of being issued."""

    digest = models.CharField(max_length=64, primary_key=True)
    user = models.ForeignKey(settings.AUTH_USER_MODEL, on_delete=models.CASCADE)
    expires = models.DateTimeField(db_index=True)
    used = models.DateTimeField(null=True, blank=True)

    def __str__(self) -> str:
        return f"ticket for {self.user} until {self.expires:%H:%M:%S}"


class FrontDoorAllowance(models.Model):
    """A further topic operators may publish, or service they may call, through the front door
    (beyond what the product's own commands cover; nothing by default). Goes through the command
    pipeline as ``frontdoor.publish`` / ``frontdoor.call``: audited, refused under the E-STOP."""

    class Kind(models.TextChoices):
        TOPIC = "topic"
        SERVICE = "service"

    kind = models.CharField(max_length=8, choices=Kind.choices)
    name = models.CharField(max_length=255, help_text="The full ROS name, e.g. /my_node/cmd.")

    class Meta:
        constraints = [models.UniqueConstraint(fields=["kind", "name"], name="frontdoor_allowance_unique")]

    def __str__(self) -> str:
        return f"{self.kind} {self.name}"


class FrontDoorPace(models.Model):
    """How often a front-door client that asks for no throttle gets a topic's messages."""

    topic = models.CharField(max_length=255, primary_key=True)
    hz = models.FloatField(validators=[MinValueValidator(0.0)], help_text="0: every message.")

    def __str__(self) -> str:
        return f"{self.topic} at {self.hz:g} Hz" if self.hz else f"{self.topic}: every message"
