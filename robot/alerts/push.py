"""Web Push with VAPID (pywebpush): the server's key pair and one encrypted message to one browser."""

from __future__ import annotations

import base64
import json
import threading
from pathlib import Path
from typing import Any

from cryptography.hazmat.primitives import serialization
from django.conf import settings
from py_vapid import Vapid
from pywebpush import WebPushException, webpush

_lock = threading.Lock()
_key: Vapid | None = None
TTL_S = 3600  # a phone that is off gets the alert within the hour, or not at all


class Gone(Exception):
    """The browser's subscription is no more (404/410): forget it."""


def _key_file() -> Path:
    return Path(settings.VAPID_PRIVATE_KEY_FILE or Path(settings.VAR_DIR) / "vapid_private.pem")


def vapid() -> Vapid:
    """The server's VAPID key: from VAPID_PRIVATE_KEY_FILE, else generated once into VAR_DIR."""
    global _key
    with _lock:
        if _key is None:
            path = _key_file()
            if not path.exists():
                key = Vapid()
                key.generate_keys()
                path.parent.mkdir(parents=True, exist_ok=True)
                key.save_key(str(path))
                path.chmod(0o600)
            _key = Vapid.from_file(str(path))
        return _key


def public_key() -> str:
    """The applicationServerKey a browser subscribes with (base64url, uncompressed point)."""
    raw = vapid().public_key.public_bytes(serialization.Encoding.X962, serialization.PublicFormat.UncompressedPoint)
    return base64.urlsafe_b64encode(raw).rstrip(b"=").decode()


def send(subscription: dict[str, Any], payload: dict[str, Any], *, timeout: float = 10) -> None:
    """Encrypt ``payload`` for one browser and hand it to its push service (blocking: from a thread)."""
    try:
        webpush(subscription, json.dumps(payload), vapid_private_key=vapid(),
                vapid_claims={"sub": settings.VAPID_SUBJECT}, timeout=timeout, ttl=TTL_S)
    except WebPushException as exc:
        if exc.response is not None and exc.response.status_code in (404, 410):
            raise Gone(subscription.get("endpoint", "")) from exc
        raise
