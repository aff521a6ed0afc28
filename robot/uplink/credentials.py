"""Uplink credentials: made, rotated and revoked here; checked when an agent connects.

A credential reads ``cyu_<key id>_<secret>``. The secret is 32 random bytes, so a plain SHA-256
of it is as good as a slow password hash and costs nothing per connection; the key id finds the row.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
from dataclasses import dataclass

from django.utils import timezone

from robot.models import UplinkCredential

PREFIX = "cyu"


def _digest(secret: str) -> str:
    return hashlib.sha256(secret.encode()).hexdigest()


def _issue(credential: UplinkCredential) -> str:
    secret = secrets.token_urlsafe(32)
    credential.secret_sha256 = _digest(secret)
    return f"{PREFIX}_{credential.key_id}_{secret}"


def credential_create(*, robot: str, label: str = "") -> tuple[UplinkCredential, str]:
    """A new credential and its text (shown once, never stored)."""
    credential = UplinkCredential(robot=robot, label=label, key_id=secrets.token_hex(6))
    text = _issue(credential)
    credential.save()
    return credential, text


def credential_issue(*, credential: UplinkCredential) -> str:
    """A fresh secret for a credential being saved for the first time (the admin's add form)."""
    credential.key_id = credential.key_id or secrets.token_hex(6)
    return _issue(credential)


def credential_rotate(*, credential: UplinkCredential) -> str:
    """A new secret for the same credential: the old one stops working at once (its live uplink closes)."""
    text = _issue(credential)
    credential.rotated = timezone.now()
    credential.save(update_fields=["secret_sha256", "rotated"])
    return text


def credential_revoke(*, credential: UplinkCredential) -> None:
    if credential.revoked is None:
        credential.revoked = timezone.now()
        credential.save(update_fields=["revoked"])


@dataclass(frozen=True)
class Accepted:
    credential_id: int
    key_id: str
    robot: str
    secret_sha256: str


def credential_check(*, text: str, robot: str) -> Accepted | None:
    """The credential ``text`` names, if it is whole, current, not revoked and for ``robot``."""
    parts = text.split("_", 2)
    if len(parts) != 3 or parts[0] != PREFIX or not parts[1] or not parts[2]:
        return None
    found = UplinkCredential.objects.filter(key_id=parts[1], robot=robot, revoked__isnull=True).first()
    if found is None or not hmac.compare_digest(found.secret_sha256, _digest(parts[2])):
        return None
    return Accepted(found.pk, found.key_id, found.robot, found.secret_sha256)


def credential_still_good(*, accepted: Accepted) -> bool:
    """Not revoked, not rotated since it was accepted (a live uplink is watched with this)."""
    return UplinkCredential.objects.filter(pk=accepted.credential_id, revoked__isnull=True,
                                           secret_sha256=accepted.secret_sha256).exists()


def credential_note_use(*, accepted: Accepted, address: str) -> None:
    UplinkCredential.objects.filter(pk=accepted.credential_id).update(last_used=timezone.now(), last_address=address)
